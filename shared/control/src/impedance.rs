//! Impedance mode (issue 14): a Cartesian virtual spring-damper about a target point,
//! rendered by the closed force loop. The force the robot should exert on the handle is
//! F = K (x₀ − x) − B ẋ (user frame, diagonal K and B), and [`crate::ForceLoop::step_direct`]
//! makes the load cell read it. K = 0 with a small B is the transparent mode: the loop then
//! cancels the muscles' own stiffness, which open loop cannot go below (K_min).

use pam_model::Vec2;

/// Largest virtual stiffness a request may carry, N/m (above 1.5 × the open loop's K_max).
pub const MAX_IMPEDANCE_STIFFNESS_N_PER_M: f32 = 5000.0;
/// Largest virtual damping a request may carry, N·s/m.
pub const MAX_IMPEDANCE_DAMPING_N_S_PER_M: f32 = 300.0;
/// Largest distance of the target from the neutral handle, m (the workspace's scale).
pub const MAX_IMPEDANCE_TARGET_M: f32 = 0.3;

/// Bandwidth of the handle-velocity filter, rad/s (encoder steps differentiated at 1 kHz
/// are noise; the operator moves below 2 Hz).
const VELOCITY_FILTER_RAD_S: f32 = 60.0;

/// A released handle: the spring asks for at least this force (norm), N…
pub const RELEASE_FORCE_MIN_N: f32 = 3.0;
/// …the load cell reads less than this fraction of it…
pub const RELEASE_FORCE_RATIO: f32 = 0.25;
/// …while the handle moves faster than this (m/s)…
pub const RELEASE_SPEED_M_S: f32 = 0.05;
/// …for this long (s). A held handle pushes back: the load cell reads the spring's force
/// within the loop's lag while the hand keeps the handle nearly still; a released one reads
/// nearly nothing while the loop accelerates the arm.
pub const RELEASE_TIME_S: f32 = 0.015;

/// Handle velocity estimate (filtered difference of the position) and the released-handle
/// detector's timer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impedance {
    fresh: bool,
    last_x_m: Vec2<f32>,
    v_m_s: Vec2<f32>,
    released_s: f32,
}

impl Default for Impedance {
    fn default() -> Self {
        Self::new()
    }
}

impl Impedance {
    pub const fn new() -> Self {
        Impedance {
            fresh: true,
            last_x_m: [0.0; 2],
            v_m_s: [0.0; 2],
            released_s: 0.0,
        }
    }

    pub fn reset(&mut self) {
        *self = Self::new();
    }

    pub fn velocity_m_s(&self) -> Vec2<f32> {
        self.v_m_s
    }

    /// The released-handle detector, once per period after [`Impedance::track`]: true once
    /// the spring has asked for at least [`RELEASE_FORCE_MIN_N`] while the load cell read
    /// less than [`RELEASE_FORCE_RATIO`] of it and the handle moved faster than
    /// [`RELEASE_SPEED_M_S`], for [`RELEASE_TIME_S`] in a row.
    pub fn released(&mut self, target_n: Vec2<f32>, measured_n: Vec2<f32>, dt_s: f32) -> bool {
        let t2 = target_n[0] * target_n[0] + target_n[1] * target_n[1];
        let m2 = measured_n[0] * measured_n[0] + measured_n[1] * measured_n[1];
        let v2 = self.v_m_s[0] * self.v_m_s[0] + self.v_m_s[1] * self.v_m_s[1];
        let r2 = RELEASE_FORCE_RATIO * RELEASE_FORCE_RATIO;
        if t2 > RELEASE_FORCE_MIN_N * RELEASE_FORCE_MIN_N
            && m2 < r2 * t2
            && v2 > RELEASE_SPEED_M_S * RELEASE_SPEED_M_S
        {
            self.released_s += dt_s;
        } else {
            self.released_s = 0.0;
        }
        self.released_s >= RELEASE_TIME_S
    }

    /// Updates the handle velocity estimate from handle position `x_m`; returns it, m/s.
    pub fn track(&mut self, x_m: Vec2<f32>, dt_s: f32) -> Vec2<f32> {
        if self.fresh {
            self.last_x_m = x_m;
            self.fresh = false;
        }
        let wdt = VELOCITY_FILTER_RAD_S * dt_s;
        let alpha = wdt / (1.0 + wdt);
        for a in 0..2 {
            let raw = (x_m[a] - self.last_x_m[a]) / dt_s;
            self.v_m_s[a] += alpha * (raw - self.v_m_s[a]);
        }
        self.last_x_m = x_m;
        self.v_m_s
    }
}

/// Lag of the closed force loop at the operator's frequencies that the spring term is led by,
/// s. The loop renders the force it is asked for late (the converters' second order behind
/// the PID: its phase delay is 13 ms at 6 rad/s and 29 ms at 10 rad/s for the designed gains,
/// docs/closed-loop.md), and a spring force rendered T late is K (x₀ − x) + K T ẋ: a negative
/// damping K T that ate the commanded B (identified 12 / 15 N·s/m for 20 at K = 300, 3.6 / 7.5
/// at K = 653 before this lead: 17–27 ms). Leading the spring by T, K (x₀ − x − T ẋ), gives
/// that damping back.
pub const IMPEDANCE_LEAD_S: f32 = 0.02;

/// F = K (x₀ − x − T ẋ) − B ẋ per axis, N, with T = [`IMPEDANCE_LEAD_S`]: the spring-damper
/// K, B rendered through a loop that lags by T.
pub fn spring_damper_force_n(
    target_m: Vec2<f32>,
    stiffness_n_per_m: Vec2<f32>,
    damping_n_s_per_m: Vec2<f32>,
    x_m: Vec2<f32>,
    v_m_s: Vec2<f32>,
) -> Vec2<f32> {
    let mut f = [0.0; 2];
    for a in 0..2 {
        f[a] = stiffness_n_per_m[a] * (target_m[a] - x_m[a] - IMPEDANCE_LEAD_S * v_m_s[a])
            - damping_n_s_per_m[a] * v_m_s[a];
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Released: asked for 9 N, reading 0.5 N, moving at 0.1 m/s, for 15 ms: yes. Held (the
    /// load cell reads the force), still, or asked for little: never.
    #[test]
    fn a_released_handle_is_one_that_reads_nothing_while_it_runs() {
        let dt = 0.001;
        let moving = |imp: &mut Impedance| {
            imp.reset();
            imp.track([0.0; 2], dt);
            imp.track([0.0001, 0.0], dt);
            for i in 2..200 {
                imp.track([0.0001 * i as f32, 0.0], dt);
            }
        };
        let mut imp = Impedance::new();
        moving(&mut imp);
        assert!(imp.velocity_m_s()[0] > 0.09);
        let runs = |imp: &mut Impedance, target: Vec2<f32>, measured: Vec2<f32>| {
            (0..30).position(|_| imp.released(target, measured, dt))
        };
        assert_eq!(runs(&mut imp, [9.0, 0.0], [0.5, 0.0]), Some(14));
        moving(&mut imp);
        assert_eq!(runs(&mut imp, [9.0, 0.0], [6.0, 0.0]), None, "held");
        moving(&mut imp);
        assert_eq!(runs(&mut imp, [2.0, 0.0], [0.0, 0.0]), None, "little asked");
        imp.reset();
        for _ in 0..200 {
            imp.track([0.01, 0.0], dt);
        }
        assert_eq!(runs(&mut imp, [9.0, 0.0], [0.0, 0.0]), None, "still");
    }

    /// At rest the spring alone; moving, the damping is B plus the lead's K·T, and K = 0
    /// leaves exactly B (transparent mode is not stiffened or damped by the lead).
    #[test]
    fn the_spring_is_led_by_the_loops_lag() {
        let (k, b) = ([300.0, 0.0], [5.0, 5.0]);
        let f = spring_damper_force_n([0.02, 0.0], k, b, [0.0; 2], [0.0; 2]);
        assert!((f[0] - 6.0).abs() < 1e-5 && f[1] == 0.0);
        let f = spring_damper_force_n([0.0; 2], k, b, [0.0; 2], [0.1, 0.1]);
        assert!(
            (f[0] + (5.0 + 300.0 * IMPEDANCE_LEAD_S) * 0.1).abs() < 1e-5,
            "{f:?}"
        );
        assert!((f[1] + 0.5).abs() < 1e-6, "{f:?}");
    }
}
