"""A scene traced and rendered from several threads at once, and edited from one while another builds: each result
is compared with the same call on a freshly built scene in this thread (the oracle)."""

import dataclasses
import importlib
import threading

import numpy as np
import pytest

import wrt
from wrt.instancing import Instances, Prototype
from wrt.scene import Scene

wrt_render = importlib.import_module("wrt.render")  # wrt.render is also the function
trace_module = importlib.import_module("wrt.trace")
scene_module = importlib.import_module("wrt.scene")

CAMERA = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
OPTIONS = dict(camera=CAMERA, width=16, height=12, device="cpu", integrator="depth")
SQUARE = np.float32([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
RAY = (np.float32([[0.2, 0.3, 3.0]]), np.float32([[0.0, 0.0, -1.0]]))


def square_scene(z: float = 0.0) -> Scene:
    return wrt.Scene(meshes=[wrt.Mesh("/Square", SQUARE + np.float32([0, 0, z]), np.int32([[0, 1, 2], [0, 2, 3]]),
                                      np.zeros(2, np.int32))])


def test_an_edit_traced_in_another_thread_while_a_renderer_builds_is_drawn_by_its_next_render(monkeypatch):
    """Thread A makes a Renderer; while its BVH is being built, thread B moves the square (``mesh.points = ...``)
    and traces the scene, which drops the caches. A then put the BVH it built of the old points into the scene's
    fresh cache, over B's, so every later trace hit the old square, and recorded the scene's cache generation after
    its build, B's drop included, so it never built again: every later render drew the old square (with the new
    points' device copy). Builds and cache drops of one scene now take turns (``Scene.lock``): B's trace waits for
    A's build, then drops it, and A's next render builds again."""
    wrt.trace(square_scene(), *RAY)  # kernels loaded before the threads start
    scene = square_scene()
    real = trace_module.BvhAccelerator
    built, b_traced = threading.Event(), threading.Event()

    def building(*args, **kwargs):
        accel = real(*args, **kwargs)
        if threading.current_thread().name == "A" and not built.is_set():
            built.set()
            # Before the lock B's trace ended within milliseconds; now it waits for this build, and A goes on.
            b_traced.wait(timeout=2.0)
        return accel

    monkeypatch.setattr(trace_module, "BvhAccelerator", building)
    made, traced = [], []
    a = threading.Thread(target=lambda: made.append(wrt.Renderer(scene, **OPTIONS)), name="A")
    a.start()
    assert built.wait(timeout=60)
    scene.meshes[0].points = SQUARE + np.float32([0, 0, 1])  # moved up by 1

    def trace_b():
        traced.append(wrt.trace(scene, *RAY).t[0])
        b_traced.set()

    b = threading.Thread(target=trace_b, name="B")
    b.start()
    a.join()
    b.join()
    monkeypatch.undo()

    fresh = square_scene(1.0)
    assert traced == [wrt.trace(fresh, *RAY).t[0]] == [2.0]
    assert wrt.trace(scene, *RAY).t[0] == 2.0
    np.testing.assert_array_equal(made[0].render().rgb, wrt.render(fresh, **OPTIONS).rgb)


def lit_square(lights: int) -> Scene:
    scene = square_scene()
    scene.lights = [wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 1.0, np.float32)),
                    wrt.DistantLight(direction=np.array([0.6, 0.0, -0.8]), color=np.full(3, 2.0, np.float32))][:lights]
    return scene


def test_a_light_appended_by_another_thread_while_a_renderer_builds_is_drawn_by_its_next_render(monkeypatch):
    """A light appended (no lock needed) after a Renderer's build uploaded the lights but before it recorded them
    was recorded as drawn: no later render uploaded it, and every image lacked it. What a build draws is now recorded
    before the build reads it, so the next render builds again."""
    scene, appended_light, fresh_scene = lit_square(1), lit_square(2).lights[1], lit_square(2)
    options = {**OPTIONS, "integrator": "whitted"}
    real = wrt_render.Renderer._upload_shading
    uploaded, appended = threading.Event(), threading.Event()

    def upload(self):
        result = real(self)
        if threading.current_thread().name == "A" and not uploaded.is_set():
            uploaded.set()
            appended.wait()  # never blocked: the main thread appends without the scene's lock
        return result

    monkeypatch.setattr(wrt_render.Renderer, "_upload_shading", upload)
    made = []
    a = threading.Thread(target=lambda: made.append(wrt.Renderer(scene, **options)), name="A")
    a.start()
    assert uploaded.wait(timeout=60)
    scene.lights.append(appended_light)
    appended.set()
    a.join()
    monkeypatch.undo()

    image = made[0].render().rgb
    fresh = wrt.render(fresh_scene, **options).rgb
    assert not np.array_equal(fresh, wrt.render(lit_square(1), **options).rgb)  # the second light shows
    np.testing.assert_array_equal(image, fresh)


def test_one_renderer_called_from_two_threads_renders_one_call_at_a_time(monkeypatch):
    """Two threads rendering with one Renderer shared its path buffers: a render of another seed made while one was
    between its launches overwrote that one's paths, and both returned images of neither seed's render (16 of 18
    images wrong: two threads, three renders each, three times). Its calls now take turns (a lock per Renderer):
    each image is that of the same render made alone."""
    scene = lit_square(2)
    options = {**OPTIONS, "integrator": "path"}
    alone = {seed: wrt.Renderer(scene, **options).render(spp=4, seed=seed).rgb for seed in (1, 2)}
    assert not np.array_equal(alone[1], alone[2])
    renderer = wrt.Renderer(scene, **options)
    real = wrt_render.Renderer._start_and_trace
    started, b_done = threading.Event(), threading.Event()

    def start_and_trace(self, *args, **kwargs):
        result = real(self, *args, **kwargs)
        if threading.current_thread().name == "A" and not started.is_set():
            started.set()
            # Before the lock B's render ended within milliseconds, in A's buffers; now it waits for A's render.
            b_done.wait(timeout=1.0)
        return result

    monkeypatch.setattr(wrt_render.Renderer, "_start_and_trace", start_and_trace)
    images = {}

    def render(seed: int) -> None:
        try:
            images[seed] = renderer.render(spp=4, seed=seed, batch=1).rgb
        finally:
            if seed == 2:
                b_done.set()

    a = threading.Thread(target=render, args=(1,), name="A")
    a.start()
    assert started.wait(timeout=60)
    b = threading.Thread(target=render, args=(2,), name="B")
    b.start()
    a.join()
    b.join()
    np.testing.assert_array_equal(images[1], alone[1])
    np.testing.assert_array_equal(images[2], alone[2])


def two_instances(shift: float) -> np.ndarray:
    """``to_world`` of two instances of the unit square, side by side, moved along x by ``shift``."""
    to_world = np.stack([np.diag([0.4, 0.4, 0.4, 1.0])] * 2)
    to_world[:, :3, 3] = [(-0.5 + shift, 0.0, 0.0), (0.5 + shift, 0.2, 0.5)]
    return to_world


def instanced_scene(shift: float) -> Scene:
    return wrt.Scene(prototypes=[Prototype("/Proto", meshes=[square_scene().meshes[0]])],
                     instances=Instances.from_transforms([0, 0], two_instances(shift)))


def test_instances_moved_by_another_thread_in_the_middle_of_a_trace_are_traced_as_moved(monkeypatch):
    """A simulation thread assigning ``instances.to_world`` each step while another thread traces: an assignment
    made after the trace had taken the instances' inverse transforms, but before it built the TLAS of their
    ``to_world``, gave a TLAS of one pose with the inverses of the other, and the trace hit the instances where
    neither pose puts them (18 to 24 of 60 traces and renders wrong in a loop of moves). Assignments now wait for a
    build in another thread (``Scene.lock``): the trace is of the pose it began with, the next of the new one."""
    grid = np.linspace(-1.2, 1.2, 13, dtype=np.float32)
    origins = np.stack([*np.meshgrid(grid, grid), np.full((13, 13), 3.0, np.float32)], -1).reshape(-1, 3)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (len(origins), 1))
    scene = instanced_scene(0.0)
    wrt.trace(scene, origins, directions)
    scene.instances.to_world = two_instances(0.1)
    real = Scene.instance_inverses
    read, assigned = threading.Event(), threading.Event()

    def inverses(self, *args, **kwargs):
        result = real(self, *args, **kwargs)
        if threading.current_thread().name == "A" and not read.is_set():
            read.set()
            assigned.wait(timeout=1.0)  # before the lock the assignment came at once; now it waits for this trace
        return result

    monkeypatch.setattr(Scene, "instance_inverses", inverses)
    traced = []
    a = threading.Thread(target=lambda: traced.append(wrt.trace(scene, origins, directions).t), name="A")
    a.start()
    assert read.wait(timeout=60)
    moved = two_instances(0.3)

    def move():
        scene.instances.to_world = moved
        assigned.set()

    b = threading.Thread(target=move, name="B")
    b.start()
    a.join()
    b.join()
    monkeypatch.undo()
    before, after = (wrt.trace(instanced_scene(shift), origins, directions).t for shift in (0.1, 0.3))
    assert not np.array_equal(before, after)
    np.testing.assert_array_equal(traced[0], before)
    np.testing.assert_array_equal(wrt.trace(scene, origins, directions).t, after)


def mirrored_instances(shift: float) -> np.ndarray:
    """:func:`two_instances`, each turned over by a mirror along x (its triangles' corners read in the other order)."""
    to_world = two_instances(shift)
    to_world[:, 0, 0] *= -1.0
    return to_world


def test_instances_mirrored_by_another_thread_after_a_trace_built_do_not_change_its_hits(monkeypatch):
    """The trace's build holds the lock, but its hits were read after it (``read_hits``) from the scene as it is then:
    instances mirrored by another thread in between swapped ``u`` and ``v`` of every hit on them, hits of the pose
    traced given the barycentrics of another. The hits are read as of the state built: those of a fresh scene in the
    pose traced."""
    grid = np.linspace(-1.2, 1.2, 13, dtype=np.float32)
    origins = np.stack([*np.meshgrid(grid, grid), np.full((13, 13), 3.0, np.float32)], -1).reshape(-1, 3)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (len(origins), 1))
    scene = instanced_scene(0.0)
    wrt.trace(scene, origins, directions)  # built before the thread starts: the move below keeps the BLASes
    real = trace_module.Accelerator.intersect
    launched, moved = threading.Event(), threading.Event()

    def intersect(self, *args, **kwargs):
        real(self, *args, **kwargs)
        if threading.current_thread().name == "A" and not launched.is_set():
            launched.set()
            moved.wait(timeout=5.0)

    monkeypatch.setattr(trace_module.Accelerator, "intersect", intersect)
    traced = []
    a = threading.Thread(target=lambda: traced.append(wrt.trace(scene, origins, directions)), name="A")
    a.start()
    assert launched.wait(timeout=60)
    scene.instances.to_world = mirrored_instances(0.0)
    moved.set()
    a.join(timeout=60)
    assert not a.is_alive()
    monkeypatch.undo()
    fresh = wrt.trace(instanced_scene(0.0), origins, directions)
    assert fresh.hit.sum() > 20 and not np.array_equal(fresh.u[fresh.hit], fresh.v[fresh.hit])
    assert traced[0] == fresh


def two_prototypes(prototype_ids) -> Scene:
    """Two instances side by side of two prototypes, a square of 2 triangles and one of 4, as ``prototype_ids``."""
    fan = wrt.Mesh("/Fan", np.float32([*SQUARE, [0, 0, 0]]), np.int32([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]),
                   np.zeros(4, np.int32))
    return wrt.Scene(prototypes=[Prototype("/Square", meshes=[square_scene().meshes[0]]), Prototype("/Fan", [fan])],
                     instances=Instances.from_transforms(prototype_ids, two_instances(0.0)))


def test_instances_replaced_by_another_thread_in_the_middle_of_a_trace_are_traced_as_replaced(monkeypatch):
    """As instances moved (above), but by a new ``scene.instances``, of the other prototype: an assignment of the
    scene's own field took no lock, and the trace built BLASes for the old instances' prototype and a TLAS of the new
    instances, which found no BLAS: it hit nothing (0 of 36 hits), and a drop of the caches that the build itself
    made on seeing the new instances left that build recorded as the new scene's, so every later trace hit nothing
    too. The assignment now waits for the build: the trace is of the instances it began with, the next of the new."""
    grid = np.linspace(-1.2, 1.2, 13, dtype=np.float32)
    origins = np.stack([*np.meshgrid(grid, grid), np.full((13, 13), 3.0, np.float32)], -1).reshape(-1, 3)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (len(origins), 1))
    scene, replaced = two_prototypes([0, 0]), Instances.from_transforms([1, 1], two_instances(0.0))
    real = Scene.instance_inverses
    read, assigned = threading.Event(), threading.Event()

    def inverses(self, *args, **kwargs):
        result = real(self, *args, **kwargs)
        if threading.current_thread().name == "A" and not read.is_set():
            read.set()
            assigned.wait(timeout=1.0)  # before the lock the assignment came at once; now it waits for this trace
        return result

    monkeypatch.setattr(Scene, "instance_inverses", inverses)
    traced = []
    a = threading.Thread(target=lambda: traced.append(wrt.trace(scene, origins, directions)), name="A")
    a.start()
    assert read.wait(timeout=60)

    def replace():
        scene.instances = replaced
        assigned.set()

    b = threading.Thread(target=replace, name="B")
    b.start()
    a.join(timeout=60)
    b.join(timeout=60)
    assert not a.is_alive() and not b.is_alive()
    monkeypatch.undo()
    before, after = (wrt.trace(two_prototypes(ids), origins, directions) for ids in ([0, 0], [1, 1]))
    assert before.hit.sum() == 36 and before != after  # the same squares, of 2 and of 4 triangles
    assert traced[0] == before
    assert wrt.trace(scene, origins, directions) == after


def test_objects_made_in_another_thread_do_not_wait_for_a_build(monkeypatch):
    """A mesh, material or instances being made are in no scene, so their constructors' assignments take no lock:
    every field after the first waited for a build of any scene in another thread (a loader thread making the next
    frame's meshes took turns with the render thread's builds). Made while a build is held in the middle, they are
    made at once."""
    scene = square_scene()
    real = trace_module.BvhAccelerator
    building, made = threading.Event(), threading.Event()
    came = []

    def build(*args, **kwargs):
        building.set()
        came.append(made.wait(timeout=2.0))  # False before: the constructors below waited for this build
        return real(*args, **kwargs)

    monkeypatch.setattr(trace_module, "BvhAccelerator", build)
    a = threading.Thread(target=lambda: wrt.trace(scene, *RAY), name="A")
    a.start()
    assert building.wait(timeout=60)
    objects = []

    def make():
        objects.extend([square_scene(2.0), wrt.Material(diffuse_color=(0.5, 0.5, 0.5)),
                        Instances.from_transforms([0, 0], two_instances(0.0)), Prototype("/P")])
        made.set()

    b = threading.Thread(target=make, name="B")
    b.start()
    a.join(timeout=60)
    b.join(timeout=60)
    assert not a.is_alive() and not b.is_alive()
    assert came == [True] and len(objects) == 4


def test_a_render_names_the_triangles_it_drew_after_another_thread_swapped_prototypes(monkeypatch):
    """A render read the scene's ids (``Scene.id_rows``) after its build, outside the lock: instances given other
    prototypes by another thread in between had the image's ``prim`` ids expanded by the new prototypes, naming
    triangles that were not drawn (or none, -1 and past the end). They are read at the build: the ids of the same
    render of a fresh scene of the prototypes drawn."""
    options = {**OPTIONS, "integrator": "depth"}
    scene = two_prototypes([0, 1])
    renderer = wrt.Renderer(scene, **options)
    real = wrt_render.Renderer._follow
    followed, swapped = threading.Event(), threading.Event()

    def follow(self):
        real(self)
        if threading.current_thread().name == "A" and not followed.is_set():
            followed.set()
            swapped.wait(timeout=5.0)

    monkeypatch.setattr(wrt_render.Renderer, "_follow", follow)
    images = []
    a = threading.Thread(target=lambda: images.append(renderer.render()), name="A")
    a.start()
    assert followed.wait(timeout=60)
    scene.instances.prototype = np.int32([1, 0])
    swapped.set()
    a.join(timeout=60)
    assert not a.is_alive()
    monkeypatch.undo()
    fresh = wrt.render(two_prototypes([0, 1]), **options)
    swapped_ids = wrt.render(two_prototypes([1, 0]), **options).aovs["prim"]
    assert not np.array_equal(fresh.aovs["prim"], swapped_ids)
    np.testing.assert_array_equal(images[0].rgb, fresh.rgb)
    np.testing.assert_array_equal(images[0].aovs["prim"], fresh.aovs["prim"])


def test_a_camera_moved_by_another_thread_while_a_render_uploads_it_is_drawn_by_the_next_render(monkeypatch):
    """A render uploading an edited camera recorded the camera after the upload: moved again by another thread in
    between, it was recorded as drawn at the second pose but uploaded at the first, and no later render uploaded it
    (every image drew the first pose). The camera is recorded before it is read: the next render draws the second
    pose, as a fresh Renderer there."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    renderer = wrt.Renderer(square_scene(), **{**OPTIONS, "camera": camera})
    poses = [wrt.Camera.look_at((x, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60).to_world for x in (0.8, -0.9)]
    real = wrt_render.Renderer._upload_cameras_at
    uploaded, moved = threading.Event(), threading.Event()

    def upload(self, *args, **kwargs):
        real(self, *args, **kwargs)
        if threading.current_thread().name == "A" and not uploaded.is_set():
            uploaded.set()
            moved.wait(timeout=5.0)

    monkeypatch.setattr(wrt_render.Renderer, "_upload_cameras_at", upload)
    camera.to_world = poses[0]
    a = threading.Thread(target=renderer.render, name="A")
    a.start()
    assert uploaded.wait(timeout=60)
    camera.to_world = poses[1]
    moved.set()
    a.join(timeout=60)
    assert not a.is_alive()
    monkeypatch.undo()
    at = [wrt.render(square_scene(), **{**OPTIONS, "camera": dataclasses.replace(camera, to_world=pose)}).rgb
          for pose in poses]
    assert not np.array_equal(*at)
    np.testing.assert_array_equal(renderer.render().rgb, at[1])


class TimedLock:
    """A renderer's lock whose waits end after ``seconds`` with TimeoutError: a deadlock fails the test (and lets go
    of the locks it held) instead of hanging it."""

    def __init__(self, seconds: float):
        self._lock, self._seconds = threading.RLock(), seconds

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        if blocking and timeout < 0:
            if not self._lock.acquire(timeout=self._seconds):
                raise TimeoutError(f"waited {self._seconds} s for the renderer's lock")
            return True
        return self._lock.acquire(blocking, timeout)

    def release(self) -> None:
        self._lock.release()

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def test_a_renderer_called_inside_scene_lock_while_another_thread_renders_with_it_does_not_deadlock(monkeypatch):
    """A simulation thread moving the scene and the cameras inside ``with scene.lock:`` (which makes edits seen all
    or none) called ``renderer.set_cameras`` while a render thread's render of that Renderer waited for the scene's
    lock holding the renderer's: each waited for the other for good. A call that finds the scene's lock taken lets
    go of the renderer's until it is free (Renderer._scene_turn): the simulation's call goes first, and the render
    draws its edits, as a fresh Renderer of the moved scene and cameras does."""
    scene = square_scene()
    renderer = wrt.Renderer(scene, **OPTIONS)
    renderer._calls = TimedLock(5.0)
    moved_camera = wrt.Camera.look_at((0.8, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    real = wrt_render.Renderer._follow
    following, locked = threading.Event(), threading.Event()

    def follow(self):
        if threading.current_thread().name == "R":
            following.set()  # it holds the renderer's lock, and asks for the scene's next
        return real(self)

    monkeypatch.setattr(wrt_render.Renderer, "_follow", follow)
    errors, images = [], []

    def simulate():
        try:
            with scene.lock:
                locked.set()
                assert following.wait(timeout=60)
                scene.meshes[0].points = SQUARE + np.float32([0, 0, 1])
                renderer.set_cameras([moved_camera])
        except Exception as error:  # noqa: BLE001 - told by the assertion below
            errors.append(error)

    s = threading.Thread(target=simulate, name="S")
    s.start()
    assert locked.wait(timeout=60)
    r = threading.Thread(target=lambda: images.append(renderer.render()), name="R")
    r.start()
    s.join(timeout=60)
    r.join(timeout=60)
    assert not s.is_alive() and not r.is_alive()
    monkeypatch.undo()
    assert errors == []
    fresh = wrt.Renderer(square_scene(1.0), **{**OPTIONS, "camera": None, "cameras": [moved_camera]}).render()
    np.testing.assert_array_equal(images[0].rgb.numpy(), fresh.rgb.numpy())  # BatchImages: device arrays


def test_a_camera_moved_by_another_thread_while_a_renderer_is_made_is_drawn_by_its_first_render(monkeypatch):
    """As a camera moved during a render's upload (above), but during the Renderer's own build, which uploads its
    cameras: the camera was recorded after the build, at its new pose, and every render drew the pose uploaded."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    moved = wrt.Camera.look_at((0.8, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60).to_world
    real = wrt_render.Renderer._upload_shading
    uploaded, done = threading.Event(), threading.Event()

    def upload(self):
        real(self)
        if threading.current_thread().name == "A" and not uploaded.is_set():
            uploaded.set()
            done.wait(timeout=5.0)

    monkeypatch.setattr(wrt_render.Renderer, "_upload_shading", upload)
    made = []
    a = threading.Thread(target=lambda: made.append(wrt.Renderer(square_scene(), **{**OPTIONS, "camera": camera})),
                         name="A")
    a.start()
    assert uploaded.wait(timeout=60)
    camera.to_world = moved
    done.set()
    a.join(timeout=60)
    assert not a.is_alive()
    monkeypatch.undo()
    fresh = wrt.render(square_scene(), **{**OPTIONS, "camera": dataclasses.replace(camera, to_world=moved)}).rgb
    np.testing.assert_array_equal(made[0].render().rgb, fresh)


class InterruptedWait:
    """A renderer's lock whose second blocking wait in the thread named R raises KeyboardInterrupt, as Ctrl-C does
    to a wait for a lock another thread holds; ``let_go`` is set when R first lets go of it."""

    def __init__(self):
        self._lock, self.waits, self.let_go = threading.RLock(), 0, threading.Event()

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        if blocking and threading.current_thread().name == "R":
            self.waits += 1
            if self.waits == 2:
                raise KeyboardInterrupt("Ctrl-C while waiting for the renderer")
        return self._lock.acquire(blocking, timeout)

    def release(self) -> None:
        self._lock.release()
        if threading.current_thread().name == "R":
            self.let_go.set()

    def _is_owned(self) -> bool:
        return self._lock._is_owned()

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def render_in_thread_r(renderer) -> tuple[threading.Thread, list]:
    """A thread named R, not started, that renders with ``renderer``, and the list of what its render raises."""
    errors = []

    def render():
        try:
            renderer.render()
        except BaseException as error:  # noqa: BLE001 - told by the callers' assertions
            errors.append(error)

    return threading.Thread(target=render, name="R"), errors


def test_a_render_interrupted_while_it_waits_for_its_renderer_back_leaves_the_renderer_as_it_was():
    """A render that found the scene's lock taken let go of its Renderer's until it was free; interrupted as it waited
    to take the Renderer's back (Ctrl-C), its call released a lock it did not hold ('cannot release un-acquired lock'
    in place of the KeyboardInterrupt) and left the renderer's count of calls at -1, so that every later first call
    counted as a nested one and waited for the scene's lock holding the renderer's: the deadlock of
    _scene_turn again. The interrupt comes through, and the renderer renders as a fresh one after it."""
    scene = square_scene()
    renderer = wrt.Renderer(scene, **OPTIONS)
    renderer._calls = InterruptedWait()
    r, errors = render_in_thread_r(renderer)
    with scene.lock:
        r.start()
        assert renderer._calls.let_go.wait(timeout=60)  # R waits for the scene's lock, not holding the renderer's
    r.join(timeout=60)
    assert not r.is_alive()
    assert [type(error) for error in errors] == [KeyboardInterrupt], errors
    assert renderer._calls_held == 0
    assert renderer._calls._lock.acquire(blocking=False)  # no thread holds it
    renderer._calls._lock.release()
    np.testing.assert_array_equal(renderer.render().rgb, wrt.render(square_scene(), **OPTIONS).rgb)


def pausing_in_a(real, inside: threading.Event, edited: threading.Event):
    """``real`` made to stop thread A where it first returns: ``inside`` is set, then A waits up to 0.5 s for
    ``edited`` (without the scene's lock held there, thread B had edited and read by then; with it, B waits)."""

    def paused(*args, **kwargs):
        result = real(*args, **kwargs)
        if threading.current_thread().name == "A" and not inside.is_set():
            inside.set()
            edited.wait(timeout=0.5)
        return result

    return paused


def read_while_edited(read, edit, inside: threading.Event, edited: threading.Event) -> None:
    """Runs ``read`` in thread A and, once it is inside (``inside``: see :func:`pausing_in_a`), ``edit`` in thread B,
    which then sets ``edited``; fails where the two wait for each other for a minute."""

    def edit_then_say():
        edit()
        edited.set()

    a = threading.Thread(target=read, name="A")
    a.start()
    assert inside.wait(timeout=60)
    b = threading.Thread(target=edit_then_say, name="B")
    b.start()
    for thread in (a, b):
        thread.join(timeout=60)
        assert not thread.is_alive(), "a read and an edit of one scene waited for each other"


@pytest.mark.parametrize("asked", ["bounds", "triangles"])
def test_a_scene_read_in_one_thread_while_another_moves_its_mesh_keeps_no_stale_cache(monkeypatch, asked):
    """Thread A asks the scene for ``bounds()`` (or ``triangles()``, a user's export or viewer) while thread B moves
    the square (``mesh.points = ...``) and reads the scene again. A's method dropped the stale caches under the lock,
    then made its value without it, and stored the old square's value into the cache B's edit had just emptied:
    from then on ``bounds()`` held the old box, and ``triangles()`` the old points, of which the next trace built its
    BVH (the old square hit at t = 3, not 2) until the next edit. A read now holds the scene's lock while it makes
    its value: B's edit waits for it, and drops it. Oracle: the same calls on a scene made with the moved square."""
    scene = square_scene()
    reading, moved = threading.Event(), threading.Event()
    monkeypatch.setattr(scene_module, "_concatenate_meshes",
                        pausing_in_a(scene_module._concatenate_meshes, reading, moved))

    def move():
        scene.meshes[0].points = SQUARE + np.float32([0, 0, 1])
        getattr(scene, asked)()

    read_while_edited(getattr(scene, asked), move, reading, moved)
    monkeypatch.undo()

    fresh = square_scene(1.0)
    np.testing.assert_array_equal(scene.bounds(), fresh.bounds())
    np.testing.assert_array_equal(scene.triangles()[0], fresh.triangles()[0])
    assert wrt.trace(scene, *RAY).t[0] == wrt.trace(fresh, *RAY).t[0] == 2.0


def test_hits_named_in_one_thread_while_another_replaces_the_mesh_are_named_as_traced(monkeypatch):
    """Thread A names the prims of hits traced on ``/Square`` (``scene.hit_paths(hits)``) while thread B replaces
    the mesh by ``/Other`` and reads the scene. ``hit_paths`` checked that the hits were of the scene as it was, then
    looked their ids up in the table of the scene as B had left it: the hits on ``/Square`` were named ``/Other``,
    without a word. The check and the look-up now hold the scene's lock together: B's edit waits for them. Oracle:
    the names of the hits asked in this thread before any edit."""
    scene = square_scene()
    hits = wrt.trace(scene, *RAY)
    expected = scene.hit_paths(hits)
    checked, replaced = threading.Event(), threading.Event()
    monkeypatch.setattr(scene_module, "check_traced_in", pausing_in_a(scene_module.check_traced_in, checked, replaced))
    named = []

    def replace():
        scene.meshes = [dataclasses.replace(scene.meshes[0], path="/Other")]
        scene.bounds()

    read_while_edited(lambda: named.append(scene.hit_paths(hits)), replace, checked, replaced)
    assert [list(part) for part in named[0]] == [list(part) for part in expected] == [["/Square"], [""]]


def test_instance_inverses_read_in_one_thread_while_another_moves_the_instances_are_not_kept_stale(monkeypatch):
    """Thread A reads ``scene.instance_inverses()`` (as ``wrt.preview`` and the far-view warnings do) while thread B
    moves the instances (``instances.to_world = ...``) and reads the scene, which drops the caches. A inverted the
    old pose without the lock and stored its inverses into the emptied cache, over B's: the next trace built a TLAS
    of the new pose with the inverses of the old one and hit the instances where neither pose puts them (until the
    next move). The read now holds the scene's lock: B's move waits for it. Oracle: a trace of a scene made with the
    moved instances, and their inverses in float64 (numpy)."""
    grid = np.linspace(-1.2, 1.2, 13, dtype=np.float32)
    origins = np.stack([*np.meshgrid(grid, grid), np.full((13, 13), 3.0, np.float32)], -1).reshape(-1, 3)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (len(origins), 1))
    scene = instanced_scene(0.0)
    scene.invalidate()  # no inverses cached: the read below makes them
    grown = two_instances(0.3)
    grown[:, :3, :3] *= 1.5  # turned or scaled, not only moved: a device transform's translation is made of to_world
    inverting, moved = threading.Event(), threading.Event()
    monkeypatch.setattr(scene_module, "invert_transforms",
                        pausing_in_a(scene_module.invert_transforms, inverting, moved))

    def move():
        scene.instances.to_world = grown
        scene.bounds()

    read_while_edited(scene.instance_inverses, move, inverting, moved)
    monkeypatch.undo()
    np.testing.assert_allclose(scene.instance_inverses()[0], np.linalg.inv(grown)[:, :3], atol=1e-12)
    fresh = wrt.trace(wrt.Scene(prototypes=scene.prototypes, instances=Instances.from_transforms([0, 0], grown)),
                      origins, directions)
    assert fresh.hit.any()
    np.testing.assert_array_equal(wrt.trace(scene, origins, directions).t, fresh.t)


def test_instance_exponents_read_in_one_thread_while_another_scales_the_instances_are_not_kept_stale(monkeypatch):
    """Thread A asks for the instances' BLAS exponents (``wrt.tlas.instance_exponents``, as the BLAS preview does)
    while thread B scales the instances by 2^-110 (past ``EXTREME_EXPONENT``) and reads the scene. A read the
    old inverses, then stored their exponents (0) into the cache B's edit had emptied: the next trace built its BLASes
    and TLAS as if the instances were of unit scale. The read now holds the scene's lock: B's edit waits for it.
    Oracle: the same function on a scene made with the scaled instances, in this thread."""
    tlas = importlib.import_module("wrt.tlas")
    scene = instanced_scene(0.0)
    scene.invalidate()
    tiny = two_instances(0.0)
    tiny[:, :3, :3] *= 2.0**-110
    inverted, scaled = threading.Event(), threading.Event()
    monkeypatch.setattr(Scene, "instance_inverses", pausing_in_a(Scene.instance_inverses, inverted, scaled))

    def scale():
        scene.instances.to_world = tiny
        scene.bounds()

    read_while_edited(lambda: tlas.instance_exponents(scene), scale, inverted, scaled)
    monkeypatch.undo()
    fresh = wrt.Scene(prototypes=scene.prototypes, instances=Instances.from_transforms([0, 0], tiny))
    expected = tlas.instance_exponents(fresh)
    assert expected.any()
    np.testing.assert_array_equal(tlas.instance_exponents(scene), expected)


def test_a_light_given_a_nan_colour_by_another_thread_while_a_renderer_builds_is_refused_by_its_next_render(
        monkeypatch):
    """Thread B gives the light a NaN colour (``light.color = ...``, an assignment without the lock) after a
    Renderer's build in thread A checked the lights but before it recorded them as drawn: the record held the NaN
    colour as checked, so no later render checked it again, and the kept Renderer drew at every render, its samples
    lit by the lamp dropped as not finite (19 of this 16x12 image's), where a new Renderer refuses it. A light that
    changed during the check is now checked again: the build refuses it (or, changed after, the next render). Oracle:
    a new Renderer of the scene as B left it."""
    light = wrt.SphereLight(position=np.array((0.5, 0.5, 4.0)), radius=0.3, color=np.array((30.0, 30.0, 30.0)),
                            path="/Lamp")
    scene = dataclasses.replace(square_scene(), lights=[light])
    options = dict(OPTIONS, integrator="path")
    real = wrt_render.check_lights
    checked, assigned = threading.Event(), threading.Event()

    def check(lights):
        real(lights)
        if threading.current_thread().name == "A" and not checked.is_set():
            checked.set()
            assigned.wait(timeout=2.0)

    monkeypatch.setattr(wrt_render, "check_lights", check)
    made = []

    def make():
        try:
            made.append(wrt.Renderer(scene, **options))
        except wrt.SceneError as error:
            made.append(error)

    a = threading.Thread(target=make, name="A")
    a.start()
    assert checked.wait(timeout=60)
    light.color = np.array([np.nan, 1.0, 1.0])
    assigned.set()
    a.join(timeout=60)
    assert not a.is_alive()
    monkeypatch.undo()
    with pytest.raises(wrt.SceneError, match="/Lamp: SphereLight color must be finite") as fresh:
        wrt.Renderer(scene, **options)
    refused = made[0]
    if isinstance(refused, wrt.Renderer):
        with pytest.raises(wrt.SceneError) as kept:
            refused.render()
        refused = kept.value
    assert str(refused) == str(fresh.value)


def test_a_cpu_trace_split_over_threads_with_per_ray_limits_and_strided_rays_gives_the_hits_of_one_thread():
    """``threads=3`` splits a launch of 40k rays into pieces (``run_in_chunks``); each piece must take its own rows of
    every per-ray array, also of ``t_min``/``t_max`` given per ray and of rays given as strided views (numpy
    columns, a ``wp.array`` taken every other row), and of the instances' ids. Oracle: the same call with
    ``threads=1`` (bit for bit), and the any-hit query against its hits."""
    import warp as wp

    rng = np.random.default_rng(5)
    scene = wrt.Scene(prototypes=[Prototype("/Proto", meshes=[square_scene().meshes[0]])],
                      instances=Instances.from_transforms([0, 0], mirrored_instances(0.1)))
    n = 2 * trace_module.MIN_RAYS_PER_THREAD + 7
    table = rng.normal(size=(n, 9))
    origins = table[:, 0:6:2] * [0.6, 0.6, 0.1] + [0.0, 0.0, 3.0]  # strided columns
    directions = table[:, 3:6] * [0.2, 0.2, 0.1] + [0.0, 0.0, -1.0]
    limits = rng.uniform(0.0, 4.0, size=(2 * n, 2))[::2]  # strided rows
    t_min, t_max = limits.min(axis=1), limits.max(axis=1)
    one = wrt.trace(scene, origins, directions, t_min=t_min, t_max=t_max, threads=1)
    assert 0 < one.hit.sum() < n and (one.instance == 1).any()
    doubled = [wp.array(np.repeat(r, 2, axis=0).astype(np.float32), dtype=wp.vec3)[::2] for r in (origins, directions)]
    for rays in ((origins, directions), doubled):
        assert wrt.trace(scene, *rays, t_min=t_min, t_max=t_max, threads=3) == one
        np.testing.assert_array_equal(wrt.occluded(scene, *rays, t_min=t_min, t_max=t_max, threads=3), one.hit)


class InterruptedAsTaken(InterruptedWait):
    """A renderer's lock whose first wait in the thread named R takes it and then raises KeyboardInterrupt: Ctrl-C
    that arrives as the wait ends, which Python raises at the call's return, the lock taken."""

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        taken = self._lock.acquire(blocking, timeout)
        if blocking and threading.current_thread().name == "R" and not self.waits:
            self.waits += 1
            raise KeyboardInterrupt("Ctrl-C as the wait for the renderer ended")
        return taken


def test_a_render_interrupted_as_it_takes_its_renderer_lets_go_of_it():
    """``one_call_at_a_time`` took the Renderer's lock before its ``try``: an interrupt (Ctrl-C) raised as the
    acquire returned, the lock taken, left it held by the interrupted thread for good, and every later call from
    another thread waited for it without end. The interrupt comes through and the lock is free after it: a render
    from another thread ends (within the join's timeout) and draws what a fresh Renderer draws."""
    scene = square_scene()
    renderer = wrt.Renderer(scene, **OPTIONS)
    renderer._calls = InterruptedAsTaken()
    r, errors = render_in_thread_r(renderer)
    r.start()
    r.join(timeout=60)
    assert not r.is_alive()
    assert [type(error) for error in errors] == [KeyboardInterrupt], errors
    image = _ends_in_time(lambda: renderer.render().rgb, seconds=30)  # fails if the interrupted render kept the lock
    assert renderer._calls_held == 0
    np.testing.assert_array_equal(image, wrt.render(square_scene(), **OPTIONS).rgb)


def _ends_in_time(call, seconds: float = 60.0):
    """``call()``'s result, run in a daemon thread that must end within ``seconds`` (a hang fails, not freezes, the
    test)."""
    out = {}

    def run():
        try:
            out["value"] = call()
        except BaseException as e:  # noqa: BLE001 (raised again in the test's thread)
            out["error"] = e

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"still running after {seconds} s (a deadlock on the scene's lock?)"
    if "error" in out:
        raise out["error"]
    return out["value"]


def test_traces_and_renders_split_over_threads_under_the_scenes_lock_end(monkeypatch):
    """Guard for the reads that hold ``scene.lock`` throughout (``of_one_state``): a thread holding it (``with
    scene.lock:`` over edits and a trace, as the README says) whose trace or render is split over a CPU thread pool
    must not wait for workers that wait for its lock (an RLock owned by the caller's thread, not the workers). Oracle:
    the same calls without the lock, ``threads=1`` (bit for bit)."""
    monkeypatch.setenv("WRT_THREADS", "2")
    scene = Scene(prototypes=[Prototype("/Proto", meshes=[square_scene().meshes[0]])],
                  instances=Instances.from_transforms([0, 0], mirrored_instances(0.1)))
    n = 2 * trace_module.MIN_RAYS_PER_THREAD
    rng = np.random.default_rng(3)
    origins = rng.normal(size=(n, 3)) * [0.6, 0.6, 0.0] + [0.0, 0.0, 3.0]
    directions = np.tile([0.0, 0.0, -1.0], (n, 1))
    one = wrt.trace(scene, origins, directions, threads=1)
    assert one.hit.any()
    named = scene.hit_paths(one)

    def locked_trace():
        with scene.lock:
            scene.instances.to_world = scene.instances.to_world.copy()  # an edit under the lock, as a user's
            hits = wrt.trace(scene, origins, directions)
            return hits, scene.hit_paths(hits)

    hits, paths = _ends_in_time(locked_trace)
    assert hits == one
    np.testing.assert_array_equal(np.asarray(paths), np.asarray(named))
    camera = wrt.Camera.look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 40.0)
    options = {"camera": camera, "width": 256, "height": 128, "device": "cpu", "integrator": "whitted"}
    expected = wrt.Renderer(scene, **options).render(spp=1, seed=0)

    def locked_render():
        with scene.lock:
            return wrt.Renderer(scene, **options).render(spp=1, seed=0)

    image = _ends_in_time(locked_render)
    np.testing.assert_array_equal(image.rgb, expected.rgb)
