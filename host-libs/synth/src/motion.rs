//! The operator's motion in a dynamic trial. A rig's users do not all move the handle the
//! same way: a few slow sines (the generator's first draw), a dense band of frequencies, the
//! reach-and-hold of a rehabilitation task (rest between reaches: friction and hysteresis at
//! standstill), or circles traced at a varying speed (both axes moving, one frequency
//! dominating). The loop must not depend on one of them. Each path is a unit path per axis
//! (value, velocity, acceleration), which `dynamic::build` scales to the trial's amplitude.

use std::f64::consts::PI;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// How the operator moves the handle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OperatorMotion {
    /// 4–8 sines per axis, 0.1–3 Hz, amplitude ∝ f^−0.6 (the generator's first motion).
    #[default]
    Sines,
    /// 60 sines per axis, 0.05 Hz up to three times a corner of 0.5–2.5 Hz, shaped by a
    /// second-order low-pass: band-limited noise, to the eye.
    Multisine,
    /// Minimum-jerk reaches of 0.5–1.8 s to random points of the disc, each followed by a
    /// hold of 0.2–2.5 s.
    ReachAndHold,
    /// An ellipse traced at 0.15–0.7 rev/s whose speed and radius vary (and whose direction
    /// reverses when the speed's swing exceeds its mean).
    Circles,
}

impl OperatorMotion {
    pub const ALL: [OperatorMotion; 4] = [
        OperatorMotion::Sines,
        OperatorMotion::Multisine,
        OperatorMotion::ReachAndHold,
        OperatorMotion::Circles,
    ];

    pub fn name(self) -> &'static str {
        match self {
            OperatorMotion::Sines => "sines",
            OperatorMotion::Multisine => "multisine",
            OperatorMotion::ReachAndHold => "reach_and_hold",
            OperatorMotion::Circles => "circles",
        }
    }
}

/// The motion of each log: one for all, or drawn per seed.
pub type MotionPlan = crate::plan::Plan<OperatorMotion>;

/// The random stream the motion's draw and its path use (the base, the effect, the noise
/// and the nuisances keep theirs, so a seed's other draws do not change with the motion).
pub const STREAM_MOTION: u64 = 5;

impl crate::plan::Choice for OperatorMotion {
    const ALL: &'static [Self] = &OperatorMotion::ALL;
    const WHAT: &'static str = "operator motion";
    const STREAM: u64 = STREAM_MOTION;
    fn name(self) -> &'static str {
        OperatorMotion::name(self)
    }
}

/// A sum of sines: (amplitude, ω, phase).
pub(crate) struct Sines {
    comps: Vec<(f64, f64, f64)>,
}

impl Sines {
    /// The first motion: a random sum of sines, 0.1–3 Hz, amplitude falling with frequency
    /// as a hand's does.
    pub(crate) fn random(rng: &mut ChaCha8Rng) -> Self {
        let n = rng.random_range(4..=8);
        let comps = (0..n)
            .map(|_| {
                let f_hz = (0.1f64.ln() + rng.random::<f64>() * (3.0f64.ln() - 0.1f64.ln())).exp();
                let amp = rng.random_range(0.3..1.0) * f_hz.powf(-0.6);
                (amp, 2.0 * PI * f_hz, rng.random_range(0.0..2.0 * PI))
            })
            .collect();
        Sines { comps }
    }

    /// Dense: 60 lines, log-spaced with jitter, under a second-order low-pass at the corner.
    fn dense(rng: &mut ChaCha8Rng) -> Self {
        let corner_hz: f64 = rng.random_range(0.5..2.5);
        let (lo, hi) = (0.05f64, 3.0 * corner_hz);
        let n = 60;
        let comps = (0..n)
            .map(|i| {
                let u = (i as f64 + rng.random::<f64>()) / n as f64;
                let f_hz = (lo.ln() + u * (hi.ln() - lo.ln())).exp();
                let r = f_hz / corner_hz;
                // |H| of a second-order low-pass (ζ = 0.7), a line's share of a log band
                let h = 1.0 / ((1.0 - r * r).powi(2) + (1.4 * r).powi(2)).sqrt();
                let amp = h * f_hz.sqrt() * rng.random_range(0.5..1.0);
                (amp, 2.0 * PI * f_hz, rng.random_range(0.0..2.0 * PI))
            })
            .collect();
        Sines { comps }
    }

    /// Value and first two derivatives.
    pub(crate) fn eval(&self, t: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for &(a, w, p) in &self.comps {
            let (s, c) = (w * t + p).sin_cos();
            out[0] += a * s;
            out[1] += a * w * c;
            out[2] -= a * w * w * s;
        }
        out
    }
}

/// Reaches between points of the unit disc, with holds.
pub(crate) struct Reaches {
    /// (start time, duration of the move, from, to); a hold fills the time to the next.
    moves: Vec<(f64, f64, [f64; 2], [f64; 2])>,
}

impl Reaches {
    fn random(rng: &mut ChaCha8Rng, duration_s: f64) -> Self {
        let mut moves = Vec::new();
        let mut at = [0.0f64; 2];
        let mut t = rng.random_range(0.0..1.0);
        while t < duration_s {
            let to = loop {
                let p: [f64; 2] = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
                let d = ((p[0] - at[0]).powi(2) + (p[1] - at[1]).powi(2)).sqrt();
                if p[0] * p[0] + p[1] * p[1] <= 1.0 && d > 0.3 {
                    break p;
                }
            };
            let move_s = rng.random_range(0.5..1.8);
            moves.push((t, move_s, at, to));
            at = to;
            t += move_s + rng.random_range(0.2..2.5);
        }
        Reaches { moves }
    }

    fn eval(&self, t: f64) -> [[f64; 3]; 2] {
        let k = self.moves.partition_point(|m| m.0 <= t);
        if k == 0 {
            return [[0.0; 3]; 2];
        }
        let (t0, d, from, to) = self.moves[k - 1];
        let u = ((t - t0) / d).clamp(0.0, 1.0);
        // minimum jerk: s = 10u³ − 15u⁴ + 6u⁵, and its derivatives in t
        let s = [
            10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5),
            (30.0 * u * u - 60.0 * u.powi(3) + 30.0 * u.powi(4)) / d,
            (60.0 * u - 180.0 * u * u + 120.0 * u.powi(3)) / (d * d),
        ];
        [0, 1].map(|ax| {
            let span = to[ax] - from[ax];
            [from[ax] + span * s[0], span * s[1], span * s[2]]
        })
    }
}

/// An ellipse, rotated, traced at a varying speed with a varying radius.
pub(crate) struct Ellipse {
    ratio: f64,
    rotation_rad: f64,
    /// θ(t) = θ0 + ω0 t + β sin(ω1 t + φ1)
    theta0: f64,
    omega0: f64,
    beta: f64,
    omega1: f64,
    phi1: f64,
    /// r(t) = 1 + ρ sin(ω2 t + φ2)
    rho: f64,
    omega2: f64,
    phi2: f64,
}

impl Ellipse {
    fn random(rng: &mut ChaCha8Rng) -> Self {
        let omega0 = 2.0 * PI * rng.random_range(0.15..0.7);
        let omega1 = 2.0 * PI * rng.random_range(0.03..0.15);
        // the speed's swing β ω1: up to 1.5 × the mean (reversals then)
        let beta = rng.random_range(0.2..1.5) * omega0 / omega1;
        Ellipse {
            ratio: rng.random_range(0.4..1.0),
            rotation_rad: rng.random_range(0.0..PI),
            theta0: rng.random_range(0.0..2.0 * PI),
            omega0,
            beta,
            omega1,
            phi1: rng.random_range(0.0..2.0 * PI),
            rho: rng.random_range(0.0..0.4),
            omega2: 2.0 * PI * rng.random_range(0.05..0.3),
            phi2: rng.random_range(0.0..2.0 * PI),
        }
    }

    fn eval(&self, t: f64) -> [[f64; 3]; 2] {
        let a1 = self.omega1 * t + self.phi1;
        let th = [
            self.theta0 + self.omega0 * t + self.beta * a1.sin(),
            self.omega0 + self.beta * self.omega1 * a1.cos(),
            -self.beta * self.omega1 * self.omega1 * a1.sin(),
        ];
        let a2 = self.omega2 * t + self.phi2;
        let w2 = self.omega2;
        let r = [
            1.0 + self.rho * a2.sin(),
            self.rho * w2 * a2.cos(),
            -self.rho * w2 * w2 * a2.sin(),
        ];
        let (s, c) = th[0].sin_cos();
        // u = r cos θ, v = e r sin θ, with their first two derivatives
        let cs = [c, -s * th[1], -c * th[1] * th[1] - s * th[2]];
        let sn = [s, c * th[1], -s * th[1] * th[1] + c * th[2]];
        let prod = |f: [f64; 3], g: [f64; 3]| {
            [
                f[0] * g[0],
                f[1] * g[0] + f[0] * g[1],
                f[2] * g[0] + 2.0 * f[1] * g[1] + f[0] * g[2],
            ]
        };
        let u = prod(r, cs);
        let v = prod(r, sn).map(|x| x * self.ratio);
        let (sr, cr) = self.rotation_rad.sin_cos();
        [
            [0, 1, 2].map(|i| cr * u[i] - sr * v[i]),
            [0, 1, 2].map(|i| sr * u[i] + cr * v[i]),
        ]
    }
}

/// The operator's path, unscaled: per axis value, velocity and acceleration.
pub(crate) enum Path {
    Sines([Sines; 2]),
    Reaches(Reaches),
    Ellipse(Ellipse),
}

impl Path {
    /// `first`: the first motion's sines, drawn from the base stream whatever the motion (so
    /// the base's later draws stay as they were); the other motions draw from `rng`.
    pub(crate) fn new(
        motion: OperatorMotion,
        first: [Sines; 2],
        rng: &mut ChaCha8Rng,
        duration_s: f64,
    ) -> Self {
        match motion {
            OperatorMotion::Sines => Path::Sines(first),
            OperatorMotion::Multisine => Path::Sines([Sines::dense(rng), Sines::dense(rng)]),
            OperatorMotion::ReachAndHold => Path::Reaches(Reaches::random(rng, duration_s)),
            OperatorMotion::Circles => Path::Ellipse(Ellipse::random(rng)),
        }
    }

    pub(crate) fn eval(&self, t: f64) -> [[f64; 3]; 2] {
        match self {
            Path::Sines(axes) => [axes[0].eval(t), axes[1].eval(t)],
            Path::Reaches(r) => r.eval(t),
            Path::Ellipse(e) => e.eval(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each path's velocity and acceleration are the derivatives of its value (central
    /// differences), so the trial's M ẍ + B ẋ is that of the motion it logs.
    #[test]
    fn derivatives_match_the_path() {
        for motion in OperatorMotion::ALL {
            let mut rng = crate::rng(11, STREAM_MOTION);
            let first = [Sines::random(&mut rng), Sines::random(&mut rng)];
            let path = Path::new(motion, first, &mut rng, 30.0);
            let h = 1e-4;
            for i in 0..300 {
                let t = 0.1 * i as f64 + 0.0137;
                let (a, b, c) = (path.eval(t - h), path.eval(t), path.eval(t + h));
                for ax in 0..2 {
                    let scale = 1.0 + b[ax][1].abs().max(b[ax][2].abs());
                    let v = (c[ax][0] - a[ax][0]) / (2.0 * h);
                    let acc = (c[ax][1] - a[ax][1]) / (2.0 * h);
                    assert!((v - b[ax][1]).abs() < 1e-5 * scale, "{motion:?} v at {t}");
                    assert!((acc - b[ax][2]).abs() < 1e-4 * scale, "{motion:?} a at {t}");
                }
            }
        }
    }

    #[test]
    fn reaches_rest_between_moves_and_circles_move_both_axes() {
        let mut rng = crate::rng(5, STREAM_MOTION);
        let first = [Sines::random(&mut rng), Sines::random(&mut rng)];
        let reach = Path::new(OperatorMotion::ReachAndHold, first, &mut rng, 60.0);
        let resting = (0..6000)
            .filter(|&i| {
                let p = reach.eval(i as f64 * 0.01);
                p[0][1].abs() < 1e-9 && p[1][1].abs() < 1e-9
            })
            .count();
        assert!((600..4800).contains(&resting), "{resting} of 6000 at rest");
        let first = [Sines::random(&mut rng), Sines::random(&mut rng)];
        let circle = Path::new(OperatorMotion::Circles, first, &mut rng, 60.0);
        let moving = (0..6000)
            .filter(|&i| {
                let p = circle.eval(i as f64 * 0.01);
                p[0][1].abs() > 1e-3 && p[1][1].abs() > 1e-3
            })
            .count();
        assert!(moving > 3000, "{moving} of 6000 with both axes moving");
    }

    #[test]
    fn the_plan_parses_and_draws_every_motion() {
        assert_eq!(
            MotionPlan::parse("circles").unwrap(),
            MotionPlan::Fixed(OperatorMotion::Circles)
        );
        assert!(MotionPlan::parse("zigzag").is_err());
        let drawn: std::collections::BTreeSet<_> = (0..200)
            .map(|s| MotionPlan::Random.for_seed(s).name())
            .collect();
        assert_eq!(drawn.len(), OperatorMotion::ALL.len());
    }
}
