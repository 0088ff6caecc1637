"""``Session.render_path``: a camera path's frames, in order, N requests in flight.

N worker threads each own a connection (the transport's per-thread keep-alive) and take frames
in path order; the generator yields them in order through a window of futures, so memory holds at
most N + 1 frames however long the path is.

A frame's camera: when the server's frame route takes camera query parameters every worker
renders in this session with its camera in the request. When it does not, a frame is "set the
camera, then render", and two such pairs interleaved in one session would render each other's
cameras; so each worker beyond the first renders in a copy of the session (snapshot restored into
a new session), which this module makes at the start and deletes at the end.
"""

from __future__ import annotations

import collections
import itertools
import queue
import time as _time
import warnings
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, Deque, Dict, Iterable, Iterator, List, Mapping, Optional

from .client import CAMERA_MEMBERS, CAMERA_QUERY, _render
from .errors import MyriadError
from .frames import Frame

if TYPE_CHECKING:
    from .client import Session


def camera_in_query(session: "Session") -> bool:
    """Whether the server's GET .../frame takes a whole camera in its query."""
    names = set(session.client.frame_parameters())
    return all(name in names for name in CAMERA_QUERY.values())


def copy_session(session: "Session") -> "Session":
    """A new session with this one's model, assets, environment and snapshot.

    Uploads are sent again from what this Session object sent (paths are read again); state
    changed by other clients' uploads cannot be copied and makes the snapshot's restore fail
    with the server's 400 naming the asset.
    """
    snapshot = session.snapshot()
    created = session._created_with
    copy = session.client.session(model=created.get("model"))
    try:
        if session._model_call is not None:
            name, kwargs = session._model_call
            getattr(copy, name)(**kwargs)
        for name, kwargs in session._replay:
            getattr(copy, name)(**kwargs)
        copy.restore(snapshot)
        if "generated" in snapshot.get("lights", {}):
            # Generated lights are restored by generating them again, which does not give the
            # lights a server made at start (--lights, --seed) for the built-in scene: send the
            # lights themselves when the copy's differ.
            ours = session.lights(0, 1000)["lights"]
            theirs = copy.lights(0, 1000)["lights"]
            if [_light_body(l) for l in ours] != [_light_body(l) for l in theirs]:
                listed = dict(snapshot, lights={"list": [_light_body(l)
                                                         for l in session.all_lights()]})
                copy.restore(listed)
    except BaseException:
        copy.delete()
        raise
    return copy


def _light_body(light: Mapping[str, Any]) -> Dict[str, Any]:
    return {key: value for key, value in light.items() if key != "id"}


# A frame the renderer refused for a full queue (503 server-busy: other clients' frames took the
# room) is asked again after a pause that doubles from the first to the last, for at most
# _BUSY_GIVE_UP_SECONDS in all; then the 503 is raised.
_BUSY_FIRST_PAUSE = 0.005
_BUSY_LAST_PAUSE = 0.5
_BUSY_GIVE_UP_SECONDS = 60.0


class _Worker:
    """A session a thread renders in; ``own_camera``: set its camera before each frame."""

    def __init__(self, session: "Session", own_camera: bool) -> None:
        self.session = session
        self.own_camera = own_camera

    def render(self, index: int, camera: Dict[str, Any], time: Optional[float],
               targets: List[str], width: Optional[int], height: Optional[int],
               options: Mapping[str, Any]) -> Frame:
        pause = _BUSY_FIRST_PAUSE
        waited = 0.0
        while True:
            try:
                return self._render_once(index, camera, time, targets, width, height, options)
            except MyriadError as error:
                if error.status != 503 or error.name != "server-busy" or \
                        waited >= _BUSY_GIVE_UP_SECONDS:
                    raise
            _time.sleep(pause)
            waited += pause
            pause = min(pause * 2, _BUSY_LAST_PAUSE)

    def _render_once(self, index: int, camera: Dict[str, Any], time: Optional[float],
                     targets: List[str], width: Optional[int], height: Optional[int],
                     options: Mapping[str, Any]) -> Frame:
        if self.own_camera:
            self.session.set_camera(camera)
            frame = _render(self.session, targets, width, height, time, options, None, index)
            frame.camera = dict(camera)
            return frame
        return _render(self.session, targets, width, height, time, options, camera, index)


def _renderer_room(session: "Session") -> Optional[int]:
    """Frames the server's renderer takes at once (one rendering plus ``maxQueuedFrames``
    waiting), or None when /v1/info does not say."""
    queued = session.client.info().get("limits", {}).get("maxQueuedFrames")
    return int(queued) + 1 if isinstance(queued, int) else None


def render_path(session: "Session", cameras: Iterable[Mapping[str, Any]], targets: List[str],
                width: Optional[int], height: Optional[int], concurrency: int,
                times: Optional[Iterable[Optional[float]]],
                options: Mapping[str, Any]) -> Iterator[Frame]:
    if concurrency < 1:
        raise ValueError(f"concurrency is at least 1, not {concurrency}")
    for member in ("target", "format", "time", *CAMERA_QUERY.values()):
        if member in options:
            raise ValueError(f"render_path sets {member!r} itself; give it through targets, "
                             f"cameras or times")
    return _generate(session, cameras, targets, width, height, concurrency, times, options)


def _generate(session: "Session", cameras: Iterable[Mapping[str, Any]], targets: List[str],
              width: Optional[int], height: Optional[int], concurrency: int,
              times: Optional[Iterable[Optional[float]]],
              options: Mapping[str, Any]) -> Iterator[Frame]:
    base_camera = session.camera()
    in_query = camera_in_query(session)
    room = _renderer_room(session)
    if room is not None and concurrency > room:
        # More would only be refused (503) and asked again: the renderer's queue is the limit.
        warnings.warn(f"render_path: the server renders {room} frames at once (one and "
                      f"maxQueuedFrames waiting); rendering with {room} of {concurrency} "
                      f"workers.", RuntimeWarning, stacklevel=3)
        concurrency = room
    workers: "queue.Queue[_Worker]" = queue.Queue()
    copies: List["Session"] = []
    pool: Optional[ThreadPoolExecutor] = None
    pending: Deque["Future[Frame]"] = collections.deque()
    completed = False
    try:
        workers.put(_Worker(session, own_camera=not in_query))
        for _ in range(concurrency - 1):
            if in_query:
                workers.put(_Worker(session, own_camera=False))
            else:
                try:
                    copy = copy_session(session)
                except MyriadError as error:
                    if error.status != 429:
                        raise
                    # The server's session limit: render with the copies made so far.
                    warnings.warn(f"render_path: {error.detail} Rendering with "
                                  f"{len(copies) + 1} of {concurrency} workers.", RuntimeWarning,
                                  stacklevel=3)
                    break
                copies.append(copy)
                workers.put(_Worker(copy, own_camera=True))
        pool = ThreadPoolExecutor(max_workers=concurrency, thread_name_prefix="myriad-path")

        def job(index: int, camera: Dict[str, Any], time: Optional[float]) -> Frame:
            worker = workers.get()
            try:
                return worker.render(index, camera, time, targets, width, height, options)
            finally:
                workers.put(worker)

        time_source = iter(times) if times is not None else itertools.repeat(None)
        for index, camera in enumerate(cameras):
            unknown = set(camera) - set(CAMERA_MEMBERS)
            if unknown:
                raise ValueError(f"camera {index} has members {sorted(unknown)}; a camera has "
                                 f"{', '.join(CAMERA_MEMBERS)}")
            whole = {**base_camera, **camera}
            try:
                time = next(time_source)
            except StopIteration:
                raise ValueError(f"times ended before camera {index}") from None
            pending.append(pool.submit(job, index, whole, time))
            if len(pending) > concurrency:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()
        completed = True
    finally:
        for future in pending:
            future.cancel()
        if pool is not None:
            pool.shutdown(wait=True)
            session.client.transport.prune()  # the workers' connections
        errors: List[MyriadError] = []
        for copy in copies:
            try:
                copy.delete()
            except MyriadError as error:
                errors.append(error)
        if not in_query:
            try:
                session.set_camera(base_camera)
            except MyriadError as error:
                errors.append(error)
        if errors and completed:  # else the error that stopped the path is the one to see
            raise errors[0]
