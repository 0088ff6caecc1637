"""The client: :class:`Client` (a server) and :class:`Session` (one scene on it)."""

from __future__ import annotations

import json
import threading
from typing import (Any, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence,
                    Tuple, Union)

from . import frames as _frames
from . import uploads
from ._transport import Query, Response, Transport
from .errors import MyriadError
from .frames import Frame
from .routes import route
from .stream import StreamFrame

JsonObject = Dict[str, Any]
Camera = Mapping[str, Any]

# Members of a camera body (camera.schema.json).
CAMERA_MEMBERS = ("eye", "target", "up", "fovY", "near", "far")
# Per-request camera query parameters of GET .../frame, when the server has them, by camera
# member (the names GET /v1/frame uses: "target" is taken by the render target there).
CAMERA_QUERY = {"eye": "eye", "target": "look_at", "up": "up", "fovY": "fov", "near": "near",
                "far": "far"}


def _vector(values: Sequence[float]) -> str:
    return ",".join(repr(float(v)) for v in values)


class Client:
    """A Myriad server.

    Args:
        url: the server, e.g. ``"http://127.0.0.1:8080"``.
        token: a session token (owner's or viewer's) used by :meth:`attach` when none is given.
        api_key: the server's ``--api-key``, needed to create sessions when it has one.
        timeout: seconds a request may wait for its answer (frames on a CPU renderer are slow).

    The client is thread-safe: each thread uses its own keep-alive connection.
    """

    def __init__(self, url: str, token: Optional[str] = None, api_key: Optional[str] = None,
                 *, timeout: float = 300.0) -> None:
        self.url = url
        self.token = token
        self.api_key = api_key
        self.transport = Transport(url, timeout=timeout)
        self._info: Optional[JsonObject] = None
        self._openapi: Optional[JsonObject] = None
        self._lock = threading.Lock()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Closes every connection (the client reconnects when used again)."""
        self.transport.close()

    def __repr__(self) -> str:
        return f"Client({self.url!r})"

    # Server-wide routes --------------------------------------------------------------------------

    @route("GET /v1/info")
    def info(self) -> JsonObject:
        """The device, limits, targets, techniques and formats (``GET /v1/info``)."""
        info = self.transport.request("GET", "/v1/info").json()
        with self._lock:
            self._info = info
        return info

    @route("GET /v1/health")
    def health(self) -> JsonObject:
        """Liveness: ``{"status": "ok"}`` while the server accepts requests."""
        return self.transport.request("GET", "/v1/health").json()

    @route("GET /v1/ready")
    def ready(self) -> bool:
        """Whether the server takes new sessions (False on 503)."""
        try:
            self.transport.request("GET", "/v1/ready")
        except MyriadError as error:
            if error.status == 503:
                return False
            raise
        return True

    @route("GET /v1/models")
    def models(self) -> List[JsonObject]:
        """The model files of the server's ``--models`` directory: ``[{"name", "bytes"}]``."""
        return self.transport.request("GET", "/v1/models").json()["models"]

    @route("GET /v1/openapi.json")
    def openapi(self) -> JsonObject:
        """The API as an OpenAPI 3.1 document (cached after the first call)."""
        with self._lock:
            cached = self._openapi
        if cached is None:
            cached = self.transport.request("GET", "/v1/openapi.json").json()
            with self._lock:
                self._openapi = cached
        return cached

    def _cached_info(self) -> JsonObject:
        with self._lock:
            info = self._info
        return info if info is not None else self.info()

    @route("GET /v1/info")
    def formats(self) -> List[str]:
        """The frame formats the server answers (``GET /v1/info`` ``formats``; cached)."""
        return list(self._cached_info().get("formats", []))

    @route("GET /v1/info")
    def max_frame_targets(self) -> int:
        """The most targets one frame request reads back (``limits.maxFrameTargets``; 8 on
        servers that do not say)."""
        return int(self._cached_info().get("limits", {}).get("maxFrameTargets", 8))

    @route("GET /v1/openapi.json")
    def frame_parameters(self) -> List[str]:
        """The query parameters ``GET /v1/sessions/{id}/frame`` takes (from the OpenAPI
        document): which options a frame may carry on this server."""
        operation = self.openapi().get("paths", {}).get("/v1/sessions/{id}/frame", {}).get("get")
        if not operation:
            return []
        return [p["name"] for p in operation.get("parameters", []) if p.get("in") == "query"]

    # Sessions ----------------------------------------------------------------------------------

    @route("POST /v1/sessions", "DELETE /v1/sessions/{id}")
    def session(self, model: Optional[str] = None, *, snapshot: Optional[JsonObject] = None,
                keep: bool = False) -> "Session":
        """Opens a session (``POST /v1/sessions``).

        Args:
            model: ``"builtin:default"`` or ``"library:NAME"`` (default: the built-in scene).
            snapshot: a snapshot (``Session.snapshot()``) to start from instead.
            keep: leave the session open when the ``with`` block ends (else it is deleted).

        Use it as a context manager: ``with client.session() as s: ...``.
        """
        body: JsonObject = {}
        if model is not None:
            body["model"] = model
        if snapshot is not None:
            body["snapshot"] = snapshot
        answer = self.transport.request(
            "POST", "/v1/sessions", body=json.dumps(body).encode("utf-8"),
            content_type="application/json", token=self.api_key, ok=(201,)).json()
        created = Session(self, answer["id"], answer["token"], keep=keep,
                          state=answer.get("session"))
        created._created_with = body
        return created

    @route("GET /v1/sessions/{id}", "DELETE /v1/sessions/{id}")
    def attach(self, session_id: str, token: Optional[str] = None, *,
               keep: bool = True) -> "Session":
        """A session that exists already (opened elsewhere, or a viewer's link), checked with
        ``GET /v1/sessions/{id}``. By default it is kept when the ``with`` block ends."""
        bearer = token or self.token
        if not bearer:
            raise ValueError("attach needs the session's token (or Client(token=...))")
        attached = Session(self, session_id, bearer, keep=keep)
        attached.state()
        return attached


class Session:
    """One session: a scene, its camera, settings, materials, lights, and its frames.

    Made by :meth:`Client.session`; a context manager that deletes the session on exit unless it
    was opened with ``keep=True``. Methods raise :class:`MyriadError` for an error answer.
    """

    def __init__(self, client: Client, session_id: str, token: str, *, keep: bool = False,
                 state: Optional[JsonObject] = None) -> None:
        self.client = client
        self.id = session_id
        self.token = token
        self.keep = keep
        self.created_state = state
        self.deleted = False
        self._created_with: JsonObject = {}
        # What render_path needs to make copies of this session: the last model set and the
        # assets and environment uploaded, to send again into each copy before its snapshot.
        self._model_call: Optional[Tuple[str, Dict[str, Any]]] = None
        self._replay: List[Tuple[str, Dict[str, Any]]] = []

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc: Any) -> None:
        if not self.keep and not self.deleted:
            try:
                self.delete()
            except MyriadError as error:
                if error.status != 404:  # already gone (expired): nothing to delete
                    raise

    def __repr__(self) -> str:
        return f"<Session {self.id} at {self.client.url}>"

    # Plumbing ----------------------------------------------------------------------------------

    def _path(self, suffix: str = "") -> str:
        return f"/v1/sessions/{self.id}{suffix}"

    def _call(self, method: str, suffix: str = "", *, query: Query = None,
              body: Any = None, ok: Iterable[int] = (200, 201, 204),
              headers: Optional[Mapping[str, str]] = None) -> Response:
        data = None
        content_type = None
        if body is not None:
            data = json.dumps(body).encode("utf-8")
            content_type = "application/json"
        return self.client.transport.request(method, self._path(suffix), query=query, body=data,
                                             content_type=content_type, token=self.token,
                                             headers=headers, ok=ok)

    def _json(self, method: str, suffix: str = "", **kwargs: Any) -> Any:
        return self._call(method, suffix, **kwargs).json()

    def _upload(self, method: str, suffix: str, source: uploads.Source,
                filename: Optional[str], query: Dict[str, Any]) -> Response:
        body = uploads.encode(source, filename)
        if body.filename is not None:
            query = dict(query, filename=body.filename)
        return self.client.transport.request(method, self._path(suffix), query=query,
                                             body=body.data, content_type=body.content_type,
                                             token=self.token, ok=(200, 201))

    # The session -------------------------------------------------------------------------------

    @route("GET /v1/sessions/{id}")
    def state(self) -> JsonObject:
        """The session state: model, camera, settings, light count, expiry."""
        return self._json("GET")

    @route("DELETE /v1/sessions/{id}")
    def delete(self) -> None:
        """Deletes the session (its GPU memory is freed before the answer)."""
        self._call("DELETE", ok=(204,))
        self.deleted = True

    @route("GET /v1/sessions/{id}/snapshot")
    def snapshot(self) -> JsonObject:
        """The whole state but the model's bytes, as one document."""
        return self._json("GET", "/snapshot")

    @route("PUT /v1/sessions/{id}/snapshot")
    def restore(self, snapshot: Mapping[str, Any]) -> JsonObject:
        """Restores a snapshot's camera, settings, materials, lights and scene (the model
        stays); returns the session state."""
        return self._json("PUT", "/snapshot", body=snapshot)

    @route("POST /v1/sessions/{id}/tokens")
    def create_token(self, role: str = "viewer", ttl_seconds: Optional[int] = None) -> JsonObject:
        """A viewer token: ``{"token", "role", "expiresInSeconds", "link"}`` (owner only)."""
        body: JsonObject = {"role": role}
        if ttl_seconds is not None:
            body["ttlSeconds"] = ttl_seconds
        return self._json("POST", "/tokens", body=body, ok=(201,))

    @route("DELETE /v1/sessions/{id}/tokens")
    def revoke_tokens(self) -> None:
        """Revokes every viewer token of the session."""
        self._call("DELETE", "/tokens", ok=(204,))

    @route("GET /v1/sessions/{id}/stats")
    def stats(self) -> JsonObject:
        """The last frame's GPU times, light culling, memory and the frame count."""
        return self._json("GET", "/stats")

    # Model and assets --------------------------------------------------------------------------

    @route("PUT /v1/sessions/{id}/model")
    def set_model(self, model: uploads.Source, *, filename: Optional[str] = None,
                  entry: Optional[str] = None, lights: Optional[str] = None) -> JsonObject:
        """Replaces the session's model; returns the new session state.

        Args:
            model: ``"builtin:default"``, ``"library:NAME"``, a path to a model file, a ``.zip``
                or a directory, bytes (with ``filename``), or ``{path: bytes}`` for several
                files (myriad.uploads says how each is sent).
            filename: the uploaded file's name, NAME.EXT (with bytes).
            entry: the model file inside a zip or several files.
            lights: ``"keep"``, ``"model"`` or ``"fit"`` (see reference.md).
        """
        query = {"entry": entry, "lights": lights}
        state = self._upload("PUT", "/model", model, filename, query).json()
        self._model_call = ("set_model", {"model": model, "filename": filename, "entry": entry,
                                          "lights": lights})
        # A new model replaces the scene: assets uploaded before are gone.
        self._replay = [call for call in self._replay if call[0] != "add_asset"]
        return state

    @route("GET /v1/sessions/{id}/assets")
    def assets(self) -> List[JsonObject]:
        """The session's assets, in the order they were added."""
        return self._json("GET", "/assets")["assets"]

    @route("POST /v1/sessions/{id}/assets")
    def add_asset(self, model: uploads.Source, *, filename: Optional[str] = None,
                  entry: Optional[str] = None) -> JsonObject:
        """Adds an asset without drawing it (same forms as :meth:`set_model`); returns it. The
        same bytes again give the same asset (the server answers 200 instead of 201)."""
        asset = self._upload("POST", "/assets", model, filename, {"entry": entry}).json()
        self._replay.append(("add_asset", {"model": model, "filename": filename, "entry": entry}))
        return asset

    @route("GET /v1/sessions/{id}/assets/{aid}")
    def asset(self, asset_id: str) -> JsonObject:
        """One asset."""
        return self._json("GET", f"/assets/{asset_id}")

    @route("DELETE /v1/sessions/{id}/assets/{aid}")
    def delete_asset(self, asset_id: str) -> None:
        """Removes an asset no object uses (409 ``conflict`` otherwise)."""
        self._call("DELETE", f"/assets/{asset_id}", ok=(204,))

    # Objects -----------------------------------------------------------------------------------

    @route("GET /v1/sessions/{id}/objects")
    def objects(self, offset: int = 0, limit: Optional[int] = None) -> JsonObject:
        """A page of objects in id order: ``{"total", "offset", "nextObjectId", "objects"}``."""
        return self._json("GET", "/objects", query={"offset": offset, "limit": limit})

    @route("GET /v1/sessions/{id}/objects")
    def all_objects(self, page: int = 1000) -> Iterator[JsonObject]:
        """Every object, fetched a page at a time."""
        offset = 0
        while True:
            answer = self.objects(offset, page)
            yield from answer["objects"]
            offset += len(answer["objects"])
            if not answer["objects"] or offset >= answer["total"]:
                return

    @route("POST /v1/sessions/{id}/objects")
    def add_objects(self, objects: Sequence[Mapping[str, Any]]) -> List[int]:
        """Adds objects (``{"asset", "name", "transform", ...}``); returns their new ids."""
        return self._json("POST", "/objects", body={"objects": list(objects)}, ok=(201,))["ids"]

    @route("GET /v1/sessions/{id}/objects/{oid}")
    def object(self, object_id: int) -> JsonObject:
        """One object."""
        return self._json("GET", f"/objects/{object_id}")

    @route("PATCH /v1/sessions/{id}/objects/{oid}")
    def patch_object(self, object_id: int, patch: Optional[Mapping[str, Any]] = None,
                     **members: Any) -> JsonObject:
        """Changes some members of an object (a dict, keywords or both); returns it."""
        return self._json("PATCH", f"/objects/{object_id}", body={**(patch or {}), **members})

    @route("DELETE /v1/sessions/{id}/objects/{oid}")
    def delete_object(self, object_id: int) -> None:
        """Removes an object and its children."""
        self._call("DELETE", f"/objects/{object_id}", ok=(204,))

    @route("POST /v1/sessions/{id}/objects/{oid}/duplicate")
    def duplicate_object(self, object_id: int, change: Optional[Mapping[str, Any]] = None,
                         **members: Any) -> List[int]:
        """Copies an object, and the objects below it unless ``children=False``, changing the
        copy's ``name``, ``transform`` or ``parent`` if given; returns the copies' ids, the
        object's copy first."""
        return self._json("POST", f"/objects/{object_id}/duplicate",
                          body={**(change or {}), **members}, ok=(201,))["ids"]

    @route("GET /v1/sessions/{id}/clock")
    def clock(self) -> JsonObject:
        """The scene clock the objects' animation clips play on:
        ``{"time", "playing", "rate", "duration"}``."""
        return self._json("GET", "/clock")

    @route("PATCH /v1/sessions/{id}/clock")
    def patch_clock(self, patch: Optional[Mapping[str, Any]] = None,
                    **members: Any) -> JsonObject:
        """Plays, pauses, seeks or changes the rate of the scene clock (``playing``, ``time``,
        ``rate``); returns the clock."""
        return self._json("PATCH", "/clock", body={**(patch or {}), **members})

    @route("GET /v1/sessions/{id}/labels")
    def labels(self, width: Optional[int] = None, height: Optional[int] = None,
               time: Optional[float] = None) -> JsonObject:
        """Per visible object of one frame: pixels, 2D box, class, 3D box, and the camera."""
        return self._json("GET", "/labels", query={"width": width, "height": height,
                                                   "time": time})

    @route("GET /v1/sessions/{id}/labels")
    def semantic_classes(self) -> Dict[str, int]:
        """The session's semantic class names and the ids the ``semantic-id`` target holds for
        them (an object given a class name as its ``semantic`` keeps that id): ``{"car": 1}``.
        Read from a 1x1 labels answer, which lists every class whatever is in view."""
        labels = self._json("GET", "/labels", query={"width": 1, "height": 1})
        return {c["name"]: c["id"] for c in labels.get("classes", [])}

    # Camera ------------------------------------------------------------------------------------

    @route("GET /v1/sessions/{id}/camera")
    def camera(self) -> JsonObject:
        """The camera: ``{"eye", "target", "up", "fovY", "near", "far"}``."""
        return self._json("GET", "/camera")

    @route("PUT /v1/sessions/{id}/camera")
    def set_camera(self, camera: Optional[Camera] = None, **members: Any) -> JsonObject:
        """Sets the whole camera (every member); returns it."""
        return self._json("PUT", "/camera", body={**(camera or {}), **members})

    @route("PATCH /v1/sessions/{id}/camera")
    def patch_camera(self, patch: Optional[Camera] = None, **members: Any) -> JsonObject:
        """Changes some members of the camera; returns the whole camera."""
        return self._json("PATCH", "/camera", body={**(patch or {}), **members})

    @route("POST /v1/sessions/{id}/camera/frame")
    def fit_camera(self) -> JsonObject:
        """Moves the camera so that the model fills the view; returns it."""
        return self._json("POST", "/camera/frame")

    @route("POST /v1/sessions/{id}/camera/select")
    def select_camera(self, index: int) -> JsonObject:
        """Makes the model file's camera ``index`` (state ``model.cameras``) the camera."""
        return self._json("POST", "/camera/select", body={"modelCamera": index})

    # Settings and materials --------------------------------------------------------------------

    @route("GET /v1/sessions/{id}/settings")
    def settings(self) -> JsonObject:
        """Sun, ambient, exposure, markers, anti-aliasing, technique, environment, shadows."""
        return self._json("GET", "/settings")

    @route("PATCH /v1/sessions/{id}/settings")
    def patch_settings(self, patch: Optional[Mapping[str, Any]] = None,
                       **members: Any) -> JsonObject:
        """Changes some settings (``sun`` members individually); returns them all."""
        return self._json("PATCH", "/settings", body={**(patch or {}), **members})

    @route("PUT /v1/sessions/{id}/environment")
    def set_environment(self, image: uploads.Source, *,
                        filename: Optional[str] = None) -> JsonObject:
        """An equirectangular Radiance ``.hdr`` as the environment light (a path, bytes, or
        ``"library:NAME.hdr"``); selects environment mode ``hdr``; returns the settings."""
        if isinstance(image, (bytes, bytearray)) and filename is None:
            filename = "upload.hdr"
        settings = self._upload("PUT", "/environment", image, filename, {}).json()
        self._replay = [call for call in self._replay if call[0] != "set_environment"]
        self._replay.append(("set_environment", {"image": image, "filename": filename}))
        return settings

    @route("GET /v1/sessions/{id}/materials")
    def materials(self) -> List[JsonObject]:
        """Every material, in id order."""
        return self._json("GET", "/materials")["materials"]

    @route("PATCH /v1/sessions/{id}/materials/{mid}")
    def patch_material(self, material_id: int, patch: Optional[Mapping[str, Any]] = None,
                       **members: Any) -> JsonObject:
        """Changes a material's factors; returns the material.

        Members (any subset): baseColor, metallic, roughness, alpha, emissive, emissiveStrength,
        normalScale, occlusionStrength, alphaMode, alphaCutoff, doubleSided, clearcoat,
        clearcoatRoughness, sheenColor, sheenRoughness, ior (1..10), specular, e.g.
        ``session.patch_material(0, clearcoat=1, sheenColor=[0.6, 0.2, 0.3])``.
        """
        return self._json("PATCH", f"/materials/{material_id}",
                          body={**(patch or {}), **members})

    # Lights ------------------------------------------------------------------------------------

    @route("GET /v1/sessions/{id}/lights")
    def lights(self, offset: int = 0, limit: Optional[int] = None) -> JsonObject:
        """A page of lights in id order: ``{"total", "offset", "lights"}``."""
        return self._json("GET", "/lights", query={"offset": offset, "limit": limit})

    @route("GET /v1/sessions/{id}/lights")
    def all_lights(self, page: int = 1000) -> Iterator[JsonObject]:
        """Every light, fetched a page at a time."""
        offset = 0
        while True:
            answer = self.lights(offset, page)
            yield from answer["lights"]
            offset += len(answer["lights"])
            if not answer["lights"] or offset >= answer["total"]:
                return

    @route("POST /v1/sessions/{id}/lights")
    def add_lights(self, lights: Sequence[Mapping[str, Any]]) -> List[int]:
        """Adds lights (``{"position", "radius", "color", "intensity", "falloff", ...}``);
        returns their new ids in order."""
        return self._json("POST", "/lights", body={"lights": list(lights)}, ok=(201,))["ids"]

    @route("POST /v1/sessions/{id}/lights/generate")
    def generate_lights(self, count: int, seed: int = 0, **options: Any) -> int:
        """Random lights from a seed (``replace``, ``bounds``, ``radius``, ``intensity``,
        ``falloff`` as keywords); returns the session's light count."""
        body = {"count": count, "seed": seed, **options}
        return self._json("POST", "/lights/generate", body=body)["total"]

    @route("DELETE /v1/sessions/{id}/lights")
    def clear_lights(self) -> None:
        """Removes every light."""
        self._call("DELETE", "/lights", ok=(204,))

    @route("GET /v1/sessions/{id}/lights/pick")
    def pick_light(self, x: float, y: float, width: int, height: int,
                   radius: Optional[float] = None) -> JsonObject:
        """The light whose marker is under pixel (x, y) of a width x height view:
        ``{"light", "distance", "candidates"}`` (no ``light`` when none is in reach)."""
        return self._json("GET", "/lights/pick", query={"x": x, "y": y, "width": width,
                                                        "height": height, "radius": radius})

    @route("GET /v1/sessions/{id}/lights/{lid}")
    def light(self, light_id: int) -> JsonObject:
        """One light."""
        return self._json("GET", f"/lights/{light_id}")

    @route("PATCH /v1/sessions/{id}/lights/{lid}")
    def patch_light(self, light_id: int, patch: Optional[Mapping[str, Any]] = None,
                    **members: Any) -> JsonObject:
        """Changes some members of a light; returns it."""
        return self._json("PATCH", f"/lights/{light_id}", body={**(patch or {}), **members})

    @route("DELETE /v1/sessions/{id}/lights/{lid}")
    def delete_light(self, light_id: int) -> None:
        """Removes one light."""
        self._call("DELETE", f"/lights/{light_id}", ok=(204,))

    # Frames ------------------------------------------------------------------------------------

    @route("GET /v1/sessions/{id}/frame")
    def image(self, target: str = "final", format: str = "png", width: Optional[int] = None,
              height: Optional[int] = None, **options: Any) -> Response:
        """One encoded frame as the server sends it: ``.body`` (PNG, JPEG or raw bytes) and
        ``.headers`` (lower-case names: ``x-myriad-intrinsics``, ``server-timing``, ...)."""
        query = {"target": target, "format": format, "width": width, "height": height, **options}
        return self._call("GET", "/frame", query=query, ok=(200,))

    @route("GET /v1/sessions/{id}/frame")
    def frame(self, targets: Union[str, Sequence[str]] = ("final",),
              width: Optional[int] = None, height: Optional[int] = None,
              time: Optional[float] = None, **options: Any) -> Frame:
        """Renders the session's scene and returns the targets as numpy arrays.

        Args:
            targets: target names (``GET /v1/info`` ``targets``), or one name.
            width, height: the size in pixels (default 1280 x 720).
            time: the animation time in seconds (default: the session's clock).
            **options: further query parameters of the frame route, e.g. ``depth="distance"``,
                ``space="camera"``.

        Returns:
            A :class:`Frame` (see myriad.frames for each target's dtype and shape) with ``K``,
            ``world_from_camera``, ``near``, ``far``, ``time`` and ``version``. With a server
            that answers ``format=npz`` it is one request for every target; otherwise one request
            per target (``final`` as PNG, the others raw).
        """
        return _render(self, _target_list(targets), width, height, time, options, None, None)

    @route("GET /v1/sessions/{id}/frame", "PUT /v1/sessions/{id}/camera",
           "GET /v1/sessions/{id}/camera", "GET /v1/sessions/{id}/snapshot",
           "POST /v1/sessions", "PUT /v1/sessions/{id}/snapshot", "DELETE /v1/sessions/{id}")
    def render_path(self, cameras: Iterable[Camera],
                    targets: Union[str, Sequence[str]] = ("final",),
                    width: Optional[int] = None, height: Optional[int] = None, *,
                    concurrency: int = 1, times: Optional[Iterable[Optional[float]]] = None,
                    **options: Any) -> Iterator[Frame]:
        """Renders a camera path and yields its frames in order, ``concurrency`` in flight.

        Args:
            cameras: camera bodies (any iterable, of any length: it is read as frames go). Each
                may give some members (``{"eye": [...]}``): the others are the session's camera
                when the path starts.
            targets, width, height, **options: as for :meth:`frame`.
            concurrency: frames requested at once, each over a connection (and thread) of its
                own; at most what the server's renderer takes at once (``/v1/info``
                ``limits.maxQueuedFrames`` + 1: more is lowered to it, with a RuntimeWarning).
                A frame refused for a full render queue (503 ``server-busy``, other clients'
                frames) is asked again after a short pause, for up to a minute.
            times: an animation time per frame (zipped with ``cameras``), or None.

        Yields:
            :class:`Frame` objects in path order, ``index`` 0, 1, 2, ... and ``camera`` set. At
            most ``concurrency + 1`` frames are held at once.

        A frame's camera travels in its request when the server's frame route takes a camera
        (``eye``, ``look_at``, ... in its OpenAPI parameters). Otherwise a frame needs the
        session's camera set first, so concurrent frames cannot share one session: each of the
        other ``concurrency - 1`` workers then renders in a copy of this session (made from its
        snapshot, with the uploads this Session made sent again; deleted when the path ends),
        and this session's camera is put back when the path ends.
        """
        from .path import render_path as _render_path
        return _render_path(self, cameras, _target_list(targets), width, height,
                            concurrency, times, options)

    @route("GET /v1/sessions/{id}/stream")
    def stream(self, target: str = "final", *, format: str = "jpeg",
               width: Optional[int] = None, height: Optional[int] = None,
               fps: Optional[int] = None, max_frames: Optional[int] = None,
               decode: bool = True, **options: Any) -> Iterator["StreamFrame"]:
        """A live view: yields a :class:`~myriad.stream.StreamFrame` whenever the scene changes
        (and every 2 s as a re-send with the same ``sequence``).

        Args:
            format: ``"jpeg"`` (decoding needs Pillow) or ``"png"``.
            max_frames: stop after this many parts (default: until the stream ends).
            decode: set ``image`` (uint8 HxWx3) on each part; else only ``data`` (bytes).

        The stream ends when the session is deleted, its token revoked or expired (a
        MyriadError with that problem is raised then), or when the iterator is closed.
        """
        from .stream import image_stream
        query = {"target": target, "format": format, "width": width, "height": height,
                 "fps": fps, **options}
        return image_stream(self, query, max_frames, decode)

    @route("GET /v1/sessions/{id}/events")
    def events(self, max_events: Optional[int] = None) -> Iterator[JsonObject]:
        """Server-Sent Events of the session: yields ``{"event": "version", "version", "role"}``
        on open and on every change, and a last ``{"event": "end", "reason"}``."""
        from .stream import event_stream
        return event_stream(self, max_events)


def _target_list(targets: Union[str, Sequence[str]]) -> List[str]:
    names = [targets] if isinstance(targets, str) else list(targets)
    if not names:
        raise ValueError("a frame needs at least one target")
    if len(set(names)) != len(names):
        raise ValueError(f"targets repeat a name: {names}")
    return names


def _camera_query(camera: Optional[Camera]) -> Dict[str, Any]:
    if camera is None:
        return {}
    query: Dict[str, Any] = {}
    for member, parameter in CAMERA_QUERY.items():
        if member in camera:
            value = camera[member]
            query[parameter] = _vector(value) if isinstance(value, (list, tuple)) else value
    return query


def _render(session: Session, targets: List[str], width: Optional[int], height: Optional[int],
            time: Optional[float], options: Mapping[str, Any], camera: Optional[Camera],
            index: Optional[int]) -> Frame:
    """One frame of ``targets``: one npz request where the server has npz, else one per target.

    ``camera`` (already whole) goes into the query: only with a server whose frame route takes
    it (render_path decides).
    """
    base = {"width": width, "height": height, "time": time, **options,
            **_camera_query(camera)}
    arrays: Dict[str, _frames.np.ndarray] = {}
    headers: Optional[Mapping[str, str]] = None
    use_npz = "npz" in session.client.formats()
    rest = list(targets)
    if use_npz:
        rest = []
        # A frame reads back at most maxFrameTargets targets (8): more go in several requests.
        per_request = session.client.max_frame_targets()
        for first in range(0, len(targets), per_request):
            group = targets[first:first + per_request]
            answer = session._call("GET", "/frame", query={**base, "target": ",".join(group),
                                                           "format": "npz"}, ok=(200,))
            members = _frames.decode_npz(answer.body, group)
            if headers is None:
                headers = answer.headers
            for target in group:
                array = members[target]
                if target in _frames.IMAGE_TARGETS and array.dtype != _frames.np.uint8:
                    rest.append(target)  # the server's npz holds linear final: take the PNG
                    continue
                arrays[target] = _frames.as_frame_array(target, array)
    for target in rest:
        image = target in _frames.IMAGE_TARGETS
        answer = session._call("GET", "/frame", query={**base, "target": target,
                                                       "format": "png" if image else "raw"},
                               ok=(200,))
        arrays[target] = (_frames.decode_image(answer.body) if image
                          else _frames.decode_raw(answer.body, answer.headers))
        if headers is None:
            headers = answer.headers
    assert headers is not None
    view = _frames.Camera(headers)
    ordered = {target: arrays[target] for target in targets}
    return Frame(ordered, K=view.K, world_from_camera=view.world_from_camera, near=view.near,
                 far=view.far, width=view.width, height=view.height,
                 time=time if time is not None else view.time,
                 version=view.version, index=index, camera=camera, headers=headers)

