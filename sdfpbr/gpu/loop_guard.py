"""The host's half of shaders/loop_guard.glsl: a counter of the invocations whose loops a
software rasterizer cut short (llvmpipe stops every loop of an invocation, silently, once all of
them have turned 65535 times), armed before a draw and read after it."""
from __future__ import annotations

import numpy as np

from ..errors import SpecError
from .programs import set_uniforms

# What loop_guard.glsl declares: read by the draw, not part of what it draws (prepasses.py leaves
# them out of the names a cached prepass's key must cover).
NAMES = ("u_guard_turns", "LoopGuard")
BINDING = 0   # the counter's storage-buffer binding


class LoopGuard:
    def __init__(self, ctx):
        self.ctx = ctx
        self.buffer = ctx.buffer(reserve=4)

    def arm(self, *programs) -> None:
        """Zero the count and bind it for the next draws of ``programs``."""
        self.buffer.write(b"\0\0\0\0")
        self.buffer.bind_to_storage_buffer(BINDING)
        for program in programs:
            set_uniforms(program, {"u_guard_turns": 2})

    def cut(self) -> int:
        """Invocations of the draws since arm() that were cut short."""
        self.ctx.memory_barrier()   # the shaders' writes, before the buffer is read
        return int(np.frombuffer(self.buffer.read(), np.uint32)[0])

    def release(self) -> None:
        self.buffer.release()


CHART_ADVICE = "lower the quality, the grid or the lights, or render on a GPU"


def cut_error(renderer: str, cut: int, what: str = "this chart", advice: str = CHART_ADVICE) -> SpecError:
    """Raised where one ray a pixel is already past the limit (fewer samples would not help)."""
    return SpecError(f"{what} needs more loop turns per pixel than the {renderer} renderer runs ({cut} pixels "
                     f"would be cut short, silently wrong): {advice}")
