"""GL programs compiled from composed sources, cached by content per context."""
from __future__ import annotations

import time

import moderngl
import numpy as np

from ..shading.compose import ComposedSource, compile_error
from ..shading.plan import compose_program


class ProgramCache:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._programs: dict[str, moderngl.Program | moderngl.ComputeShader] = {}
        self._vertex = compose_program("fullscreen_vert.glsl")
        self.compile_seconds = 0.0   # total spent compiling, for the benchmark

    def fragment(self, source: ComposedSource, vertex: ComposedSource | None = None) -> moderngl.Program:
        """``source`` drawn by the fullscreen triangle, or by ``vertex``'s geometry."""
        vertex = vertex or self._vertex
        key = "frag:" + source.digest + ("" if vertex is self._vertex else ":" + vertex.digest)
        if key not in self._programs:
            start = time.perf_counter()
            try:
                self._programs[key] = self.ctx.program(vertex_shader=vertex.text, fragment_shader=source.text)
            except Exception as exc:   # moderngl raises a bare Error with the driver log
                raise compile_error(source, exc) from None
            self.compile_seconds += time.perf_counter() - start
        return self._programs[key]

    def digests(self) -> list[str]:
        """The composed sources compiled so far (fragment and compute, and vertex programs
        other than the fullscreen triangle's), by digest."""
        return [digest for key in self._programs for digest in key.split(":")[1:]]

    def compute(self, source: ComposedSource) -> moderngl.ComputeShader:
        key = "comp:" + source.digest
        if key not in self._programs:
            start = time.perf_counter()
            try:
                self._programs[key] = self.ctx.compute_shader(source.text)
            except Exception as exc:
                raise compile_error(source, exc) from None
            self.compile_seconds += time.perf_counter() - start
        return self._programs[key]


def set_uniforms(program, values: dict) -> None:
    """Set the uniforms the program has; composed-out features simply have none."""
    for name, value in values.items():
        if name in program:
            member = program[name]
            if isinstance(value, list):   # uniform arrays (all float here): write packed data
                member.write(np.asarray(value, np.float32).tobytes())
            else:
                member.value = value
