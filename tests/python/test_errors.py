"""MyriadError: the RFC 9457 problem of every error answer, and the client's own failures."""

from __future__ import annotations

import socket

import pytest

import myriad
from conftest import LIGHTS, MAX_LIGHTS


def test_invalid_body_names_the_member(session):
    with pytest.raises(myriad.MyriadError) as caught:
        session.set_camera({**session.camera(), "eye": [1, 2000000, 3]})
    error = caught.value
    assert error.status == 400
    assert error.type == "https://myriad.dev/problems/invalid-body"
    assert error.name == "invalid-body"
    assert error.title == "Invalid request body"
    assert error.pointer == "/eye/1"
    assert error.detail == '"eye/1" must be at most 1000000, got 2000000.'
    assert error.problem["status"] == 400
    assert error.method == "PUT" and error.url.endswith(f"/v1/sessions/{session.id}/camera")
    assert "400 invalid-body" in str(error) and "/eye/1" in str(error)


def test_unknown_member_and_parameter(session):
    with pytest.raises(myriad.MyriadError) as caught:
        session.patch_camera(zoom=2)
    assert caught.value.pointer == "/zoom"
    assert '"zoom" is not a member' in caught.value.detail
    with pytest.raises(myriad.MyriadError) as caught:
        session.lights(limit=5000)
    assert caught.value.status == 400 and caught.value.name == "invalid-parameter"
    assert caught.value.parameter == "limit"
    with pytest.raises(myriad.MyriadError) as caught:
        session.image("depth", "raw", 16, 16, zoom=2)
    assert caught.value.name == "unknown-parameter" and caught.value.parameter == "zoom"


def test_limit_exceeded_names_the_limit(client, session):
    with pytest.raises(myriad.MyriadError) as caught:
        session.generate_lights(MAX_LIGHTS + 1, seed=1)
    error = caught.value
    assert error.status == 413 and error.name == "limit-exceeded"
    assert error.limit == "maxLightsPerSession"
    assert str(MAX_LIGHTS) in error.detail
    assert session.lights()["total"] == LIGHTS  # nothing was added


def test_too_many_sessions_is_429_with_retry_after(client):
    info = client.info()
    limit, open_before = info["limits"]["maxSessions"], info["sessions"]["open"]
    opened = []
    try:
        with pytest.raises(myriad.MyriadError) as caught:
            for _ in range(limit + 1):
                opened.append(client.session())
        error = caught.value
        assert error.status == 429 and error.limit == "maxSessions"
        assert error.retry_after is not None and error.retry_after >= 1
        assert len(opened) == limit - open_before
    finally:
        for s in opened:
            s.delete()


def test_tokens_and_missing_sessions(client, session):
    wrong = myriad.Session(client, session.id, "0" * 64)
    with pytest.raises(myriad.MyriadError) as caught:
        wrong.camera()
    assert caught.value.status == 401 and caught.value.name == "unauthorized"
    with client.session() as other:
        borrowed = myriad.Session(client, session.id, other.token)
        with pytest.raises(myriad.MyriadError) as caught:
            borrowed.camera()
        assert caught.value.status == 403 and caught.value.name == "forbidden"
    with pytest.raises(myriad.MyriadError) as caught:
        client.attach(session.id, other.token)  # deleted with its with-block
    assert caught.value.status in (401, 404)
    gone = client.session()
    gone.delete()
    with pytest.raises(myriad.MyriadError) as caught:
        gone.frame("depth", 8, 8)
    assert caught.value.status == 404 and caught.value.name == "not-found"
    with pytest.raises(ValueError, match="token"):
        client.attach(session.id)


def test_a_server_that_is_not_there_is_status_0():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free, and nothing listens once closed
    with pytest.raises(myriad.MyriadError) as caught:
        myriad.Client(f"http://127.0.0.1:{port}", timeout=5).health()
    assert caught.value.status == 0 and caught.value.name == "connection-failed"


def test_api_key_of_a_server_that_wants_one():
    from conftest import ServerProcess
    key = "test-key-0123456789"
    process = ServerProcess(["--api-key", key])
    try:
        anonymous = myriad.Client(process.url)
        assert anonymous.info()["apiKeyRequired"] is True
        with pytest.raises(myriad.MyriadError) as caught:
            anonymous.session()
        assert caught.value.status == 401 and caught.value.name == "unauthorized"
        with pytest.raises(myriad.MyriadError) as caught:
            myriad.Client(process.url, api_key="wrong").session()
        assert caught.value.status == 401
        keyed = myriad.Client(process.url, api_key=key)
        with keyed.session() as s:
            assert s.frame("depth", 8, 8)["depth"].shape == (8, 8)
            # A session's own token, not the key, opens it: attach with Client(token=...).
            viewer = myriad.Client(process.url, token=s.token).attach(s.id)
            assert viewer.camera() == s.camera()
        assert process.stop() == 0
        assert "[vulkan-validation]" not in process.stderr()
    finally:
        process.close()
