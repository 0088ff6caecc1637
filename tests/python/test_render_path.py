"""render_path: frames in path order, each the frame of its camera, N requests in flight."""

from __future__ import annotations

import itertools
import math
import threading

import numpy as np
import pytest

import myriad
import myriad.path
from myriad import _transport
from conftest import PLAIN_CUBE_OBJ

W, H = 48, 32
TARGETS = ["final", "depth", "instance-id"]


def orbit(count, radius=7.0, height=3.0):
    for i in range(count):
        angle = 2 * math.pi * i / count
        yield {"eye": [radius * math.cos(angle), height, radius * math.sin(angle)],
               "target": [0.0, 0.5, 0.0]}


def assert_same(a, b):
    assert list(a) == list(b)
    for target in a:
        assert np.array_equal(a[target], b[target]), target
    assert np.array_equal(a.K, b.K) and np.array_equal(a.world_from_camera, b.world_from_camera)


@pytest.fixture
def in_flight(monkeypatch):
    """Counts GET .../frame requests in flight at once, and the most seen."""
    state = {"now": 0, "most": 0, "frames": 0}
    lock = threading.Lock()
    original = _transport.Transport.request

    def counting(self, method, path, **kwargs):
        if not path.endswith("/frame"):
            return original(self, method, path, **kwargs)
        with lock:
            state["now"] += 1
            state["frames"] += 1
            state["most"] = max(state["most"], state["now"])
        try:
            return original(self, method, path, **kwargs)
        finally:
            with lock:
                state["now"] -= 1

    monkeypatch.setattr(_transport.Transport, "request", counting)
    return state


@pytest.mark.parametrize("concurrency", [1, 3])
def test_frames_come_in_order_and_equal_single_frames(session, concurrency, in_flight):
    cameras = list(orbit(7))
    start_camera = session.camera()
    path = list(session.render_path(cameras, TARGETS, W, H, concurrency=concurrency))
    assert [f.index for f in path] == list(range(7))
    assert session.camera() == start_camera  # put back after the path
    assert in_flight["most"] == concurrency
    for frame, camera in zip(path, cameras):
        assert frame.camera["eye"] == camera["eye"]
        assert np.allclose(frame.world_from_camera[:3, 3], camera["eye"], atol=1e-4)
    # Each frame is the frame of its camera, rendered alone, bit for bit.
    for i in (0, 4, 6):
        session.set_camera({**start_camera, **cameras[i]})
        assert_same(path[i], session.frame(TARGETS, W, H))
    frames_differ = not np.array_equal(path[0]["depth"], path[3]["depth"])
    assert frames_differ


def test_concurrent_paths_equal_a_serial_path_in_an_uploaded_scene(client, session):
    session.set_model(PLAIN_CUBE_OBJ, filename="cube.obj")
    asset = session.add_asset({"cube.obj": PLAIN_CUBE_OBJ})
    added = session.add_objects([{"asset": asset["id"],
                                  "transform": {"translation": [1.5, 0, 0]}, "semantic": 4}])
    root = session.objects()["objects"][0]["id"]
    session.generate_lights(40, seed=3)
    session.patch_settings(exposure=1.7)
    open_before = client.info()["sessions"]["open"]
    cameras = [{"eye": [4.0, 2.0 + 0.3 * i, 4.0], "target": [0.5, 0.5, 0.0], "near": 0.05,
                "far": 50.0} for i in range(6)]
    serial = list(session.render_path(cameras, TARGETS, W, H, concurrency=1))
    parallel = list(session.render_path(cameras, TARGETS, W, H, concurrency=3))
    for a, b in zip(serial, parallel):
        assert_same(a, b)
    assert set(np.unique(serial[0]["instance-id"]).tolist()) == {0, root, added[0]}
    assert client.info()["sessions"]["open"] == open_before  # the copies are gone


def test_an_endless_path_holds_bounded_memory_and_stops_cleanly(client, session, in_flight):
    open_before = client.info()["sessions"]["open"]

    def endless():
        for i in itertools.count():
            yield {"eye": [6.0, 2.0 + 0.01 * (i % 100), 6.0]}

    frames = session.render_path(endless(), ["depth"], 16, 16, concurrency=2)
    taken = list(itertools.islice(frames, 12))
    assert [f.index for f in taken] == list(range(12))
    # Read ahead by at most the window: concurrency frames in flight past the one taken.
    assert in_flight["frames"] <= 12 + 2
    frames.close()
    assert client.info()["sessions"]["open"] == open_before
    # The workers' connections were closed with them: only this thread's is left.
    transport = client.transport
    assert len(transport._connections) <= 1


def test_times_and_bad_paths(session):
    session.patch_settings(animate=True)
    times = [0.0, 1.0, 0.0]
    path = list(session.render_path([{}, {}, {}], ["final"], W, H, times=times))
    assert [f.time for f in path] == times
    assert np.array_equal(path[0]["final"], path[2]["final"])
    assert not np.array_equal(path[0]["final"], path[1]["final"])  # the lights moved
    with pytest.raises(ValueError, match="members"):
        list(session.render_path([{"zoom": 2}], ["final"], W, H))
    with pytest.raises(ValueError, match="concurrency"):
        session.render_path([{}], ["final"], W, H, concurrency=0)
    with pytest.raises(myriad.MyriadError) as caught:
        list(session.render_path([{"fovY": 600}], ["final"], W, H))
    # Refused by the server: as the camera's query parameter (a camera for one frame) or, on a
    # server without one, as the camera route's body member.
    assert caught.value.status == 400
    assert caught.value.parameter == "fov" or caught.value.pointer == "/fovY"


def test_a_full_server_renders_with_the_copies_it_could_make(client, session, in_flight,
                                                            monkeypatch):
    # The path for a server whose frames take no camera in the query (older servers): session
    # copies, as many as the server has room for.
    monkeypatch.setattr(myriad.path, "camera_in_query", lambda _session: False)
    info = client.info()
    room = info["limits"]["maxSessions"] - info["sessions"]["open"]
    fillers = [client.session() for _ in range(room - 1)]  # room for one copy only
    try:
        with pytest.warns(RuntimeWarning, match="2 of 3 workers"):
            path = list(session.render_path(orbit(5), ["depth"], 16, 16, concurrency=3))
        assert [f.index for f in path] == list(range(5))
        assert in_flight["most"] == 2
    finally:
        for filler in fillers:
            filler.delete()


def test_a_server_taking_the_camera_in_the_query_needs_no_copies(client, session, monkeypatch):
    """The path a server with per-frame camera parameters takes (eye, look_at, up, fov, near,
    far on GET .../frame, as GET /v1/frame has): emulated here by setting the camera just before
    the frame, under a lock, where the server would take it from the query."""
    camera_names = ["eye", "look_at", "up", "fov", "near", "far"]
    names = client.frame_parameters() + camera_names
    monkeypatch.setattr(myriad.Client, "frame_parameters", lambda self: names)
    made = []
    original_session = myriad.Client.session
    monkeypatch.setattr(myriad.Client, "session",
                        lambda self, *a, **k: made.append(1) or original_session(self, *a, **k))
    seen = []
    lock = threading.Lock()
    original_call = myriad.Session._call

    def emulate(self, method, suffix="", *, query=None, **kwargs):
        if method == "PUT" and suffix == "/camera":
            raise AssertionError("render_path set the camera although the query carries it")
        if suffix == "/frame" and query and "eye" in query:
            with lock:
                seen.append(dict(query))
                vector = lambda text: [float(v) for v in text.split(",")]  # noqa: E731
                camera = {"eye": vector(query["eye"]), "target": vector(query["look_at"]),
                          "up": vector(query["up"]), "fovY": query["fov"],
                          "near": query["near"], "far": query["far"]}
                original_call(self, "PUT", "/camera", body=camera)
                rest = {k: v for k, v in query.items() if k not in camera_names}
                return original_call(self, method, suffix, query=rest, **kwargs)
        return original_call(self, method, suffix, query=query, **kwargs)

    monkeypatch.setattr(myriad.Session, "_call", emulate)
    cameras = list(orbit(5))
    path = list(session.render_path(cameras, ["depth"], W, H, concurrency=3))
    assert [f.index for f in path] == list(range(5)) and made == []
    assert sorted(q["eye"] for q in seen) == sorted(
        ",".join(repr(float(v)) for v in c["eye"]) for c in cameras)
    assert all(q["look_at"] == "0.0,0.5,0.0" for q in seen)
    for frame, camera in zip(path, cameras):
        assert np.allclose(frame.world_from_camera[:3, 3], camera["eye"], atol=1e-4)


def test_concurrency_is_lowered_to_what_the_renderer_takes(client, session, in_flight):
    room = client.info()["limits"]["maxQueuedFrames"] + 1
    with pytest.warns(RuntimeWarning, match=f"rendering with {room} of {room + 3} workers"):
        frames = list(session.render_path(orbit(2 * room), TARGETS, W, H,
                                          concurrency=room + 3))
    assert [f.index for f in frames] == list(range(2 * room))
    assert in_flight["most"] <= room


def test_a_busy_renderer_is_asked_again(session, monkeypatch):
    """A 503 server-busy (the render queue full of other clients' frames) is retried after a
    pause; any other problem is raised at once."""
    original = myriad.path._render
    refusals = {"left": 3, "asked": 0}

    def busy_at_first(*args, **kwargs):
        refusals["asked"] += 1
        if refusals["left"] > 0:
            refusals["left"] -= 1
            raise myriad.MyriadError(503, {
                "type": "https://myriad.dev/problems/server-busy", "title": "Server busy",
                "status": 503, "detail": "The renderer is busy."}, retry_after=1.0)
        return original(*args, **kwargs)

    monkeypatch.setattr(myriad.path, "_render", busy_at_first)
    frames = list(session.render_path(orbit(2), TARGETS, W, H))
    assert [f.index for f in frames] == [0, 1] and refusals["asked"] == 5

    def refused(*args, **kwargs):
        raise myriad.MyriadError(413, {
            "type": "https://myriad.dev/problems/limit-exceeded", "title": "Too large",
            "status": 413, "detail": "Too many pixels."})

    monkeypatch.setattr(myriad.path, "_render", refused)
    with pytest.raises(myriad.MyriadError) as raised:
        list(session.render_path(orbit(2), TARGETS, W, H))
    assert raised.value.status == 413
