"""Every route the client wraps, against the real server: values, counts and statuses."""

from __future__ import annotations

import io
import threading
import zipfile

import numpy as np
import pytest

import myriad
from conftest import CUBE_MTL, CUBE_OBJ, LIGHTS, PLAIN_CUBE_OBJ, radiance_hdr


def test_server_wide_routes(client):
    assert client.health() == {"status": "ok"}
    assert client.ready() is True
    info = client.info()
    assert info["server"]["name"] == "myriad-server"
    assert "depth" in info["targets"] and "instance-id" in info["targets"]
    assert set(client.formats()) >= {"png", "jpeg", "raw"}
    assert client.models() == []  # no --models directory
    assert client.openapi()["openapi"].startswith("3.1")
    assert {"target", "format", "width", "height", "time"} <= set(client.frame_parameters())


def test_session_lifecycle_and_context_manager(client):
    with client.session() as s:
        state = s.state()
        assert state["id"] == s.id
        assert state["lights"]["count"] == LIGHTS
        assert s.created_state["id"] == s.id
        assert s.stats()["frames"] == 0
    with pytest.raises(myriad.MyriadError) as caught:
        s.state()
    assert caught.value.status == 404 and caught.value.name == "not-found"
    with client.session(keep=True) as kept:
        pass
    assert kept.state()["id"] == kept.id  # kept: still there
    attached = client.attach(kept.id, kept.token)
    assert attached.camera() == kept.camera()
    kept.delete()
    assert kept.deleted


def test_snapshot_restore_and_copy(client, session):
    session.patch_settings(exposure=2.5)
    session.add_lights([{"position": [1, 1, 1], "radius": 2, "color": [1, 0, 0],
                         "intensity": 3, "falloff": 1}])
    snapshot = session.snapshot()
    assert snapshot["settings"]["exposure"] == 2.5
    assert len(snapshot["lights"]["list"]) == LIGHTS + 1
    with client.session(snapshot=snapshot) as copy:
        assert copy.settings()["exposure"] == 2.5
        assert copy.lights()["total"] == LIGHTS + 1
    session.patch_settings(exposure=1.0)
    state = session.restore(snapshot)
    assert state["settings"]["exposure"] == 2.5


def test_viewer_tokens(client, session):
    token = session.create_token(ttl_seconds=120)
    assert token["role"] == "viewer" and 0 < token["expiresInSeconds"] <= 120
    assert token["token"] in token["link"]
    viewer = client.attach(session.id, token["token"])
    assert viewer.camera() == session.camera()
    with pytest.raises(myriad.MyriadError) as caught:
        viewer.patch_camera(fovY=30)
    assert caught.value.status == 403 and caught.value.name == "forbidden"
    assert "viewer" in caught.value.detail
    session.revoke_tokens()
    with pytest.raises(myriad.MyriadError) as caught:
        viewer.camera()
    assert caught.value.status == 401 and "revoked" in caught.value.detail


def test_camera_routes(session):
    camera = session.camera()
    assert set(camera) == {"eye", "target", "up", "fovY", "near", "far"}
    put = session.set_camera({**camera, "eye": [6.0, 4.0, 6.0]})
    assert put["eye"] == [6.0, 4.0, 6.0]
    patched = session.patch_camera(fovY=30)
    assert patched["fovY"] == 30 and patched["eye"] == [6.0, 4.0, 6.0]
    fitted = session.fit_camera()
    assert fitted["eye"] != [6.0, 4.0, 6.0]
    with pytest.raises(myriad.MyriadError) as caught:
        session.select_camera(0)  # the built-in scene has no cameras
    assert caught.value.status == 400 and caught.value.pointer == "/modelCamera"


def test_settings_environment_and_materials(session):
    settings = session.settings()
    assert settings["technique"] in ("volumes", "tiled", "clustered")
    patched = session.patch_settings({"sun": {"intensity": 5}}, technique="tiled")
    assert patched["sun"]["intensity"] == 5 and patched["technique"] == "tiled"
    env = session.set_environment(radiance_hdr(), filename="grey.hdr")
    assert env["environment"]["mode"] == "hdr"
    assert env["environment"]["source"] == "upload:grey.hdr"
    materials = session.materials()
    assert len(materials) == session.state()["model"]["materials"]
    changed = session.patch_material(0, baseColor=[0.9, 0.1, 0.1], roughness=0.2)
    assert changed["id"] == 0 and changed["baseColor"] == pytest.approx([0.9, 0.1, 0.1])
    assert session.materials()[0]["roughness"] == pytest.approx(0.2)


def test_lights(session):
    assert session.generate_lights(300, seed=7, radius=[0.5, 1.0]) == 300
    page = session.lights(offset=290, limit=20)
    assert page["total"] == 300 and page["offset"] == 290 and len(page["lights"]) == 10
    assert len(list(session.all_lights(page=128))) == 300
    ids = session.add_lights([
        {"position": [0, 2, 0], "radius": 3, "color": [1, 1, 1], "intensity": 4, "falloff": 1},
        {"position": [0, 3, 0], "radius": 10, "color": [1, 1, 1], "intensity": 20,
         "falloff": 0, "type": "spot", "direction": [0, -1, 0], "innerConeAngle": 0.35,
         "outerConeAngle": 0.52, "attenuation": "inverse-square"}])
    assert len(ids) == 2 and ids[1] == ids[0] + 1
    assert session.light(ids[1])["type"] == "spot"
    assert session.patch_light(ids[0], intensity=8)["intensity"] == 8
    session.delete_light(ids[0])
    with pytest.raises(myriad.MyriadError) as caught:
        session.light(ids[0])
    assert caught.value.status == 404
    assert session.lights()["total"] == 301
    pick = session.pick_light(160, 120, 320, 240, radius=64)
    assert pick["candidates"] >= 0
    session.clear_lights()
    assert session.lights()["total"] == 0


def test_model_uploads_in_every_form(session, tmp_path):
    state = session.set_model(PLAIN_CUBE_OBJ, filename="cube.obj")
    assert state["model"]["source"] == "upload:cube.obj"
    (tmp_path / "cube").mkdir()
    (tmp_path / "cube" / "cube.obj").write_bytes(CUBE_OBJ)
    (tmp_path / "cube" / "cube.mtl").write_bytes(CUBE_MTL)
    state = session.set_model(tmp_path / "cube" / "cube.obj")  # a path; its .mtl is not sent
    assert state["model"]["source"] == "upload:cube.obj"
    state = session.set_model(tmp_path / "cube")  # a directory: multipart
    assert state["model"]["source"] == "upload:cube.obj"
    assert session.materials()[0]["baseColor"] == pytest.approx([0.8, 0.1, 0.1])
    state = session.set_model({"cube.obj": CUBE_OBJ, "cube.mtl": CUBE_MTL}, entry="cube.obj")
    assert state["model"]["source"] == "upload:cube.obj"
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("cube/cube.obj", CUBE_OBJ)
        z.writestr("cube/cube.mtl", CUBE_MTL)
    state = session.set_model(archive.getvalue(), filename="cube.zip")
    assert state["model"]["source"] == "upload:cube.zip"
    state = session.set_model("builtin:default")
    assert state["model"]["source"] == "builtin:default"
    with pytest.raises(myriad.MyriadError) as caught:
        session.set_model(b"not a model", filename="broken.obj")
    assert caught.value.status == 422 and caught.value.name == "model-rejected"


def test_assets_and_objects(session):
    asset = session.add_asset({"cube.obj": CUBE_OBJ, "cube.mtl": CUBE_MTL})
    assert asset["id"].startswith("a-") and asset["objects"] == 0
    again = session.add_asset({"cube.obj": CUBE_OBJ, "cube.mtl": CUBE_MTL})
    assert again["id"] == asset["id"]  # content-addressed
    assert [a["id"] for a in session.assets()][-1] == asset["id"]
    assert session.asset(asset["id"])["meshes"] >= 1
    before = session.objects(limit=0)["total"]
    ids = session.add_objects([{"asset": asset["id"], "name": f"cube{i}",
                                "transform": {"translation": [i * 1.5 - 3, 0, 0]},
                                "semantic": 7} for i in range(5)])
    assert len(ids) == 5
    page = session.objects(offset=before + 1, limit=3)
    assert page["total"] == before + 5 and [o["id"] for o in page["objects"]] == ids[1:4]
    assert len(list(session.all_objects(page=2))) == before + 5
    assert session.object(ids[0])["name"] == "cube0"
    moved = session.patch_object(ids[0], transform={"translation": [0, 0.5, 0]}, visible=False)
    assert moved["visible"] is False and moved["transform"]["translation"] == [0, 0.5, 0]
    copies = session.duplicate_object(ids[1], name="cube1 copy",
                                      transform={"translation": [0, 2, 0]})
    assert len(copies) == 1 and copies[0] > ids[-1]
    copy = session.object(copies[0])
    assert copy["name"] == "cube1 copy" and copy["asset"] == asset["id"]
    assert copy["transform"]["translation"] == [0, 2, 0] and copy["semantic"] == 7
    assert session.duplicate_object(copies[0]) == [copies[0] + 1]
    with pytest.raises(myriad.MyriadError) as caught:
        session.duplicate_object(ids[1], parent=4000000)
    assert caught.value.status == 400 and caught.value.pointer == "/parent"
    ids += [copies[0], copies[0] + 1]
    with pytest.raises(myriad.MyriadError) as caught:
        session.delete_asset(asset["id"])
    assert caught.value.status == 409 and caught.value.name == "conflict"
    for oid in ids:
        session.delete_object(oid)
    assert session.objects()["total"] == before
    session.delete_asset(asset["id"])
    with pytest.raises(myriad.MyriadError) as caught:
        session.asset(asset["id"])
    assert caught.value.status == 404


def test_labels_and_stats(session):
    labels = session.labels(width=64, height=48)
    assert labels["width"] == 64 and labels["height"] == 48
    assert labels["objects"] and all(o["pixels"] > 0 for o in labels["objects"])
    session.frame(["final"], 32, 24)
    stats = session.stats()
    assert stats["frames"] >= 1 and stats["frame"]["width"] == 32


def test_semantic_classes_name_the_ids_of_the_semantic_target(session):
    others = [o["id"] for o in session.all_objects() if o["visible"]]
    for oid in others:
        session.patch_object(oid, visible=False)
    asset = session.assets()[0]["id"]
    ids = session.add_objects([{"asset": asset, "semantic": "car"},
                               {"asset": asset, "semantic": "tree", "visible": False}])
    try:
        classes = session.semantic_classes()
        assert {"car", "tree"} <= set(classes) and classes["car"] != classes["tree"]
        assert session.object(ids[0])["semantic"] == "car"  # an object reads back its name
        # The only visible object is the car: the semantic-id target holds its class id and 0.
        mask = session.frame(["semantic-id"], 32, 24)["semantic-id"]
        assert set(np.unique(mask).tolist()) == {0, classes["car"]}
    finally:
        for oid in ids:
            session.delete_object(oid)
        for oid in others:
            session.patch_object(oid, visible=True)


def test_events_and_stream(session):
    first = next(session.events(max_events=1))
    assert first["event"] == "version" and first["role"] == "owner"
    parts = list(session.stream(format="png", width=32, height=24, fps=10, max_frames=1))
    assert len(parts) == 1
    assert parts[0].content_type == "image/png" and parts[0].image.shape == (24, 32, 3)
    assert parts[0].sequence >= 1
    # The PNG part is the frame of the same state, pixel for pixel.
    assert np.array_equal(parts[0].image, session.frame("final", 32, 24)["final"])
    jpeg = next(session.stream(width=40, height=30, max_frames=1, quality=90))
    assert jpeg.content_type == "image/jpeg" and jpeg.image.shape == (30, 40, 3)
    raw = next(session.stream(width=40, height=30, max_frames=1, decode=False))
    assert raw.image is None and raw.data[:2] == b"\xff\xd8"


def test_a_stream_and_events_end_with_the_session(client):
    doomed = client.session()
    stream = doomed.stream(format="png", width=16, height=16, fps=5)
    events = doomed.events()
    assert next(stream).image.shape == (16, 16, 3)
    assert next(events)["event"] == "version"
    deleter = threading.Timer(0.5, doomed.delete)
    deleter.start()
    with pytest.raises(myriad.MyriadError) as caught:
        for _ in stream:  # re-sends every 2 s until the session is gone
            pass
    assert caught.value.status == 404 and caught.value.name == "not-found"
    rest = list(events)
    assert rest[-1] == {"event": "end", "reason": "deleted"}
    deleter.join()


def test_scene_clock_when_the_server_has_it(client, session):
    if "/v1/sessions/{id}/clock" not in client.openapi()["paths"]:
        pytest.skip("this server has no scene clock yet (issue 29)")
    clock = session.clock()
    assert {"time", "playing", "rate", "duration"} <= set(clock)
    paused = session.patch_clock(playing=False, time=1.5)
    assert paused["playing"] is False and paused["time"] == 1.5
    assert session.patch_clock(rate=0.5)["rate"] == 0.5
    with pytest.raises(myriad.MyriadError) as caught:
        session.patch_clock(rate=1000)
    assert caught.value.status == 400 and caught.value.pointer == "/rate"
