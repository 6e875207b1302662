// Whether a software rasterizer cut this invocation's loops short. llvmpipe ends every loop of
// a shader, silently, once all of its loops together have turned 65535 times (gallivm's
// LP_MAX_TGSI_LOOP_ITERATIONS: one count for the whole shader, per SIMD vector of 4-16
// invocations, each loop spending as many turns as its slowest lane); past that a loop still
// runs its body once, since the count is tested at a turn's end. A loop that should turn twice
// (u_guard_turns, a uniform the compiler cannot fold) then turns once, and the invocation
// counts itself in u_loops_cut, which the host reads after the draw (gpu/loop_guard.py).
layout(std430, binding = 0) buffer LoopGuard { uint u_loops_cut; };
uniform int u_guard_turns;

// Whether this invocation's loops were cut short (and counted so).
bool loops_cut() {
    int turns = 0;
    for (int i = 0; i < u_guard_turns; ++i) turns++;
    if (turns == u_guard_turns) return false;
    atomicAdd(u_loops_cut, 1u);
    return true;
}

void loop_guard() {
    loops_cut();
}
