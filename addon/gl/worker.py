"""A thread that owns one standalone moderngl context.

moderngl.create_context(standalone=True) makes its context current on the calling
thread. Inside Blender that thread may hold Blender's own GL context (UI, or a render
thread with bl_use_gpu_context), so every GL call of the offscreen renderer runs on
this private thread instead; callers submit work and wait for its result.
"""
from __future__ import annotations

import queue
import threading


class GLWorker:
    def __init__(self, factory):
        """factory() runs on the worker thread and returns the moderngl context."""
        self._jobs: queue.Queue = queue.Queue()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self.ctx = None
        self._thread = threading.Thread(target=self._loop, args=(factory,),
                                        name="splatline-gl", daemon=True)
        self._thread.start()
        self._ready.wait()
        if self._error is not None:
            raise RuntimeError(f"could not create the OpenGL context: {self._error}") from self._error

    def _loop(self, factory):
        try:
            self.ctx = factory()
        except BaseException as exc:  # reported to the constructor's caller
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        while True:
            job = self._jobs.get()
            if job is None:
                break
            fn, args, box, done = job
            try:
                box["result"] = fn(*args)
            except BaseException as exc:
                box["error"] = exc
            done.set()
        self.ctx.release()
        self.ctx = None

    def call(self, fn, *args):
        """Run fn(*args) on the GL thread and return its result (or raise its error)."""
        if not self.alive:
            raise RuntimeError("the offscreen renderer is closed")
        if threading.current_thread() is self._thread:
            return fn(*args)
        box, done = {}, threading.Event()
        self._jobs.put((fn, args, box, done))
        done.wait()
        if "error" in box:
            raise box["error"]
        return box.get("result")

    @property
    def alive(self) -> bool:
        return self._thread.is_alive() and self._error is None

    def close(self, cleanup=None):
        """Run cleanup (if any) on the thread, release the context, join the thread."""
        if not self.alive:
            return
        if cleanup is not None:
            self.call(cleanup)
        self._jobs.put(None)
        self._thread.join()
