"""session.frame: every target's dtype and shape, equal bit for bit to the single-target answers."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from PIL import Image

import myriad
from myriad import frames as frames_module
from myriad import png

W, H = 64, 48
FLOAT_TARGETS = {"albedo": 3, "normal": 3, "position": 3, "uv": 2, "metallic": 1,
                 "roughness": 1, "depth": 1, "emissive": 3, "occlusion": 1, "light-count": 1}
LABELS = ("instance-id", "semantic-id", "material-id")


def raw_array(session, target, **options):
    answer = session.image(target, "raw", W, H, **options)
    dtype = np.uint32 if answer.header("x-myriad-dtype") == "uint32" else np.float32
    channels = answer.header("x-myriad-channels").split(",")
    array = np.frombuffer(bytes(answer.body), dtype="<u4" if dtype == np.uint32 else "<f4")
    return array.reshape(H, W, len(channels)).squeeze(axis=2) if len(channels) == 1 else \
        array.reshape(H, W, len(channels))


def test_every_target_has_its_documented_dtype_and_shape(session):
    targets = ["final", *FLOAT_TARGETS, *LABELS]
    frame = session.frame(targets, W, H)
    assert list(frame) == targets and len(frame) == len(targets)
    assert frame["final"].dtype == np.uint8 and frame["final"].shape == (H, W, 3)
    for target, channels in FLOAT_TARGETS.items():
        assert frame[target].dtype == np.float32, target
        assert frame[target].shape == ((H, W) if channels == 1 else (H, W, channels)), target
    for target in LABELS:
        assert frame[target].dtype == np.uint32 and frame[target].shape == (H, W)
    assert frame.width == W and frame.height == H
    with pytest.raises(KeyError, match="no target 'clusters'"):
        frame["clusters"]


def test_multi_target_frame_equals_single_target_answers_bit_for_bit(session):
    frame = session.frame(["final", "depth", "normal", "instance-id"], W, H)
    for target in ("depth", "normal", "instance-id"):
        expected = raw_array(session, target)
        assert frame[target].dtype == expected.dtype
        assert np.array_equal(frame[target].view(np.uint32), expected.view(np.uint32)), target
    png_bytes = bytes(session.image("final", "png", W, H).body)
    pil = np.asarray(Image.open(io.BytesIO(png_bytes)).convert("RGB"))
    assert np.array_equal(frame["final"], pil)
    assert np.array_equal(png.decode(png_bytes)[:, :, :3], pil)  # the package's own reader
    # The scene is not empty: depth below far somewhere, its object, a lit image.
    assert (frame["depth"] < frame.far).sum() > W * H // 4
    assert set(np.unique(frame["instance-id"]).tolist()) == {0, 1}  # the sky and the one object
    assert frame["final"].max() > 64
    norms = np.linalg.norm(frame["normal"], axis=2)
    surface = frame["instance-id"] > 0
    assert np.allclose(norms[surface], 1.0, atol=1e-3)


def test_camera_of_a_frame(session):
    frame = session.frame(["depth"], W, H)
    answer = session.image("depth", "raw", W, H)
    intrinsics = json.loads(answer.header("x-myriad-intrinsics"))
    assert frame.K.shape == (3, 3) and frame.K.dtype == np.float64
    assert frame.K[0, 0] == intrinsics["fx"] and frame.K[1, 1] == intrinsics["fy"]
    assert frame.K[0, 2] == W / 2 and frame.K[1, 2] == H / 2 and frame.K[2, 2] == 1
    assert frame.intrinsics["near"] == intrinsics["near"] == frame.near
    pose = frame.world_from_camera
    assert pose.shape == (4, 4) and np.array_equal(pose[3], [0, 0, 0, 1])
    assert np.allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-5)
    assert np.allclose(pose[:3, 3], session.camera()["eye"], atol=1e-5)
    # Lift the centre pixel with K and the pose: it lands on the surface the position target has.
    both = session.frame(["depth", "position"], W, H)
    v, u = H // 2, W // 2
    z = both["depth"][v, u]
    camera_point = np.array([(u + 0.5 - frame.K[0, 2]) * z / frame.K[0, 0],
                             (v + 0.5 - frame.K[1, 2]) * z / frame.K[1, 1], z, 1.0])
    assert np.allclose((pose @ camera_point)[:3], both["position"][v, u], atol=1e-2)


def test_frame_options_reach_the_server(session):
    distance = session.frame(["depth"], W, H, depth="distance")["depth"]
    assert np.array_equal(distance, raw_array(session, "depth", depth="distance"))
    z = session.frame(["depth"], W, H)["depth"]
    assert (distance >= z - 1e-4).all() and (distance > z + 1e-3).any()
    camera_normals = session.frame("normal", W, H, space="camera")["normal"]
    assert np.array_equal(camera_normals, raw_array(session, "normal", space="camera"))
    timed = session.frame(["depth"], W, H, time=2.5)
    assert timed.time == 2.5


def test_frame_errors_are_problems(session):
    with pytest.raises(myriad.MyriadError) as caught:
        session.frame(["depth", "no-such-target"], W, H)
    error = caught.value
    assert error.status == 400 and error.name == "invalid-parameter"
    assert error.parameter == "target" and "no-such-target" in error.detail
    with pytest.raises(myriad.MyriadError) as caught:
        session.frame(["depth"], 100000, H)
    assert caught.value.status == 400 and caught.value.parameter == "width"
    with pytest.raises(ValueError, match="repeat"):
        session.frame(["depth", "depth"], W, H)


def test_npz_when_the_server_has_it(client, session):
    if "npz" not in client.formats():
        pytest.skip("this server has no format=npz yet: frames took one request per target")
    targets = ["final", "depth", "normal", "instance-id"]
    frame = session.frame(targets, W, H)
    for target in targets[1:]:
        assert np.array_equal(frame[target], raw_array(session, target)), target
    answer = session.image(",".join(targets), "npz", W, H)
    members = frames_module.decode_npz(answer.body, targets)
    assert members["K"].shape == (3, 3) and np.allclose(members["K"], frame.K)
    assert np.allclose(members["world_from_camera"], frame.world_from_camera)


def test_version_and_time_of_a_frame(session):
    first = session.frame("depth", W, H)
    if first.version is None:
        pytest.skip("this server sends no X-Myriad-Version yet")
    assert isinstance(first.version, int) and first.time == 0.0
    session.patch_settings(exposure=1.5)
    second = session.frame("depth", W, H)
    assert second.version > first.version
    assert session.frame("depth", W, H, time=3.0).time == 3.0


def test_npz_members_are_read_in_place_and_equal_numpy_load():
    rng = np.random.default_rng(3)
    arrays = {"final": rng.integers(0, 256, (5, 7, 3), dtype=np.uint8),
              "depth": rng.random((5, 7), dtype=np.float32),
              "instance-id": rng.integers(0, 9, (5, 7), dtype=np.uint32), "K": np.eye(3)}
    for save in (np.savez, np.savez_compressed):
        buffer = io.BytesIO()
        save(buffer, **arrays)
        body = bytearray(buffer.getvalue())
        members = frames_module.decode_npz(body, ["final", "depth", "instance-id"])
        assert set(members) == set(arrays)
        for name, array in arrays.items():
            assert members[name].dtype == array.dtype and np.array_equal(members[name], array)
        in_place = frames_module._stored_npz(body) is not None
        assert in_place == (save is np.savez)
    with pytest.raises(ValueError):  # not an npz at all
        frames_module.decode_npz(bytearray(b"garbage"), ["depth"])


def test_server_npz_is_read_in_place(client, session):
    if "npz" not in client.formats():
        pytest.skip("this server has no format=npz yet")
    answer = session.image("final,depth,instance-id", "npz", W, H)
    members = frames_module._stored_npz(answer.body)
    assert members is not None  # stored members, read without a copy
    assert members["depth"].flags.writeable
    with np.load(io.BytesIO(bytes(answer.body))) as reference:
        for name in reference.files:
            assert np.array_equal(members[name], reference[name]), name
