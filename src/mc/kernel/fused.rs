//! The fused mechanical step of one chunk of lanes (`BatchState::fused_step` in `step/state.rs`):
//! the step kernel, the Heun velocity update and the free flight while the chunk is in
//! registers, the same arithmetic as the unfused loops.

use crate::mc::compile::impact::meets;
use crate::mc::compile::lanes::LaneProgram;

/// The step sizes of a fused step and the barrier's position (if any).
pub(in crate::mc) struct Kinematics {
    pub(in crate::mc) h: f64,
    pub(in crate::mc) sqrt_h: f64,
    pub(in crate::mc) tau: f64,
    pub(in crate::mc) at: Option<f64>,
}

#[inline(always)]
pub(in crate::mc) fn chunk<const W: usize>(s: &[f64]) -> &[f64; W] {
    s.try_into().expect("a chunk of W lanes")
}

#[inline(always)]
pub(in crate::mc) fn chunk_mut<const W: usize>(s: &mut [f64]) -> &mut [f64; W] {
    s.try_into().expect("a chunk of W lanes")
}

/// One fused step of `W` lanes (see `BatchState::fused_step`): the step kernel's outputs
/// f, σ, ∂f/∂v, the Heun update of `v` and the flight `xn = x + v·τ`; bit i set when lane
/// i met the barrier (W ≤ 64).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(in crate::mc) fn fused_chunk<const W: usize>(
    program: &LaneProgram,
    slots: &mut [[f64; W]],
    x: &[f64; W],
    v: &mut [f64; W],
    z: &[f64; W],
    side: &[f64; W],
    xn: &mut [f64; W],
    k: &Kinematics,
) -> u64 {
    program.run(x, v, slots);
    let (f0, sigma, slope) = (
        &slots[program.output(0)],
        &slots[program.output(1)],
        &slots[program.output(2)],
    );
    let (h, sqrt_h, tau) = (k.h, k.sqrt_h, k.tau);
    for i in 0..W {
        let dw = z[i] * (sigma[i] * sqrt_h);
        let f1 = f0[i] + slope[i] * (f0[i] * h + dw);
        let vn = v[i] + (0.5 * (f0[i] + f1) * h + dw);
        v[i] = vn;
        xn[i] = x[i] + vn * tau;
    }
    let mut met = 0u64;
    if let Some(b) = k.at {
        for i in 0..W {
            met |= (meets(b, side[i], x[i], xn[i]) as u64) << i;
        }
    }
    met
}
