//! Gain-plane feed-forward (§5.4, eq. 5.2): the measured force is G(α)·command, so the
//! command is divided by the fitted G.

use crate::mat2::Vec2;
use crate::params::GainPlane;
use crate::real::Real;

impl<R: Real> GainPlane<R> {
    /// G(α1, α2) = p1·α1 + p2·α2 + p3 for axis 0 (X) or 1 (Y).
    #[inline]
    pub fn gain(&self, axis: usize, alpha_rad: Vec2<R>) -> R {
        let p = &self.coeffs[axis & 1];
        p[0] * alpha_rad[0] + p[1] * alpha_rad[1] + p[2]
    }

    /// The corrected force command: each axis divided by its gain. A gain below
    /// `min_gain` (or NaN) is raised to `min_gain` so the correction stays bounded; the
    /// returned flag says when that happened.
    pub fn correct(&self, force_ref_n: Vec2<R>, alpha_rad: Vec2<R>) -> (Vec2<R>, bool) {
        let mut limited = false;
        let mut out = [R::ZERO; 2];
        for axis in 0..2 {
            let g = self.gain(axis, alpha_rad);
            let g_used = if g >= self.min_gain { g } else { self.min_gain };
            limited |= !(g >= self.min_gain);
            out[axis] = force_ref_n[axis] / g_used;
        }
        (out, limited)
    }
}
