"""What reading one render target back costs on this machine, four ways: the texture
(glGetTexImage) or its framebuffer (glReadPixels), into fresh memory or into an array kept
between reads. frame.read_rgba takes the framebuffer into a kept array: on an H100 the
texture read moved 0.9 GB/s, glReadPixels into mapped memory 8-10 GB/s.

    python -m sdfpbr.devtools.bench.readback [SIZE ...]      (default 1024 2048 4096)
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from ...gpu.frame import GL_DTYPES

DTYPES = {code: dtype.type for dtype, code in GL_DTYPES.items()}   # "f1" -> np.uint8, ...


def probe(ctx, size: int, dtype: str, repeats: int = 15) -> dict[str, float]:
    """Median ms of each way of reading a (size, size) RGBA target of ``dtype``, a draw before each."""
    import moderngl
    program = ctx.program(
        vertex_shader="#version 330\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);"
                      " gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }",
        fragment_shader="#version 330\nout vec4 c;\nvoid main() { c = vec4(fract(gl_FragCoord.xy * 0.01), 0.5, 1.0); }")
    vao = ctx.vertex_array(program, [])
    texture = ctx.texture((size, size), 4, dtype=dtype)
    fbo = ctx.framebuffer([texture])
    kept = np.empty((size, size, 4), DTYPES[dtype])
    ways = {
        "texture, fresh": lambda: texture.read(),
        "texture, kept": lambda: texture.read_into(kept),
        "framebuffer, fresh": lambda: fbo.read(components=4, dtype=dtype),
        "framebuffer, kept": lambda: fbo.read_into(kept, components=4, dtype=dtype),
    }
    out = {}
    try:
        for name, read in ways.items():
            times = []
            for _ in range(repeats):
                fbo.use()
                vao.render(moderngl.TRIANGLES, vertices=3)
                ctx.finish()                      # the draw is not part of the read
                start = time.perf_counter()
                read()
                times.append(time.perf_counter() - start)
            out[name] = 1000 * statistics.median(times)
    finally:
        for obj in (vao, fbo, texture, program):
            obj.release()
    return out


def main(argv: list[str] | None = None) -> None:
    from ...gpu.gl import create_context, renderer_string
    sizes = [int(a) for a in (sys.argv[1:] if argv is None else argv)] or [1024, 2048, 4096]
    ctx = create_context("auto")
    print(f"# {renderer_string(ctx)}; ms, medians of 15")
    with ctx:
        for size in sizes:
            for dtype in DTYPES:
                row = probe(ctx, size, dtype)
                print(f"{size}² {dtype}: " + " | ".join(f"{k} {v:.1f}" for k, v in row.items()), flush=True)


if __name__ == "__main__":
    main()
