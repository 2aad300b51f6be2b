//! The thesis's experiment protocols as the model computes them: the joint stiffness of a
//! Table 4.1 trial and of the §5.2 force-step test, the static trial's nine holds and the
//! force-step sequence. The twin runs them on the simulated rig and `pamctl experiment`
//! on the device; both take them from here. Host-side (f64): the firmware only executes
//! the modes these protocols command.

use crate::thesis::{STEP_MAX_N, STEP_N};
use crate::{RobotModel, Vec2};

/// The joint stiffness a Table 4.1 trial runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StiffnessLevel {
    /// K_low = K_min (Table 4.1).
    Low,
    /// K_high = K_max − 0.2 (K_max − K_min).
    High,
}

impl StiffnessLevel {
    pub const ALL: [StiffnessLevel; 2] = [StiffnessLevel::Low, StiffnessLevel::High];

    /// `low` or `high`, as on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            StiffnessLevel::Low => "low",
            StiffnessLevel::High => "high",
        }
    }
}

/// A stiffness level that is neither `low` nor `high`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnknownStiffnessLevel;

impl core::fmt::Display for UnknownStiffnessLevel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the stiffness level is `low` or `high`")
    }
}

impl core::str::FromStr for StiffnessLevel {
    type Err = UnknownStiffnessLevel;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        StiffnessLevel::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or(UnknownStiffnessLevel)
    }
}

/// Joint stiffness of a Table 4.1 trial at `alpha_rad` (from the model's capability).
pub fn trial_stiffness(
    model: &RobotModel<f64>,
    alpha_rad: Vec2<f64>,
    level: StiffnessLevel,
) -> Vec2<f64> {
    let mut k = [0.0; 2];
    for j in 0..2 {
        let (lo, hi) = model.capability(j, alpha_rad[j]).trial_stiffness_levels();
        k[j] = match level {
            StiffnessLevel::Low => lo,
            StiffnessLevel::High => hi,
        };
    }
    k
}

/// The §5.2 step test's largest forces, ±27.3 N along X and along Y: the torques every
/// co-contraction of the test must hold.
const STEP_EXTREMES_N: [Vec2<f64>; 4] = [
    [STEP_MAX_N, 0.0],
    [-STEP_MAX_N, 0.0],
    [0.0, STEP_MAX_N],
    [0.0, -STEP_MAX_N],
];

/// §5.2: per joint, the minimum stiffness at the torques of ±27.3 N along X and along Y; the
/// highest of those.
pub fn step_test_stiffness(model: &RobotModel<f64>, alpha_rad: Vec2<f64>) -> Vec2<f64> {
    let mut k = [0.0f64; 2];
    for f in STEP_EXTREMES_N {
        let tau = model.kinematics.joint_torques(alpha_rad, f);
        for j in 0..2 {
            let cap = model.capability(j, alpha_rad[j]);
            let k_min = match cap.stiffness_range(tau[j]) {
                Some((lo, _)) => lo,
                None => cap.k_max.stiffness_nm_per_rad,
            };
            k[j] = k[j].max(k_min);
        }
    }
    k
}

/// The share of the muscles' pressure range the step test's high co-contraction keeps every
/// step's pressure under: a converter whose gain is a few per cent high would otherwise
/// reach its own full scale at the largest steps, a ceiling the trial did not set out to
/// look for.
pub const STEP_HIGH_PRESSURE_SHARE: f64 = 0.9;

/// The §5.2 step test at another co-contraction: per joint, `Low` is
/// [`step_test_stiffness`] (the least that holds every step), `High` is 80 % of the way from
/// it to the most that every step's torque still allows (as Table 4.1's K_high keeps a
/// fifth of the range in hand), less where a step's pressure would pass
/// [`STEP_HIGH_PRESSURE_SHARE`] of the range. The same steps at a higher co-contraction
/// raise every muscle's pressure: a supply's ceiling is then crossed by more of them, while
/// the converters' spread keeps its share, which is how the model loop tells the two apart.
pub fn step_test_stiffness_at(
    model: &RobotModel<f64>,
    alpha_rad: Vec2<f64>,
    level: StiffnessLevel,
) -> Vec2<f64> {
    let lo = step_test_stiffness(model, alpha_rad);
    if level == StiffnessLevel::Low {
        return lo;
    }
    let mut hi = [f64::INFINITY; 2];
    for f in STEP_EXTREMES_N {
        let tau = model.kinematics.joint_torques(alpha_rad, f);
        for j in 0..2 {
            if let Some((_, k)) = model.capability(j, alpha_rad[j]).stiffness_range(tau[j]) {
                hi[j] = hi[j].min(k);
            }
        }
    }
    let top = [0, 1].map(|j| {
        if hi[j].is_finite() {
            hi[j].max(lo[j])
        } else {
            lo[j]
        }
    });
    let at = |share: f64| [0, 1].map(|j| lo[j] + share * (top[j] - lo[j]));
    let ceiling_bar = STEP_HIGH_PRESSURE_SHARE * model.params.pressure.max_bar;
    let within = |k: Vec2<f64>| {
        step_levels().iter().all(|&level| {
            (0..2).all(|axis| {
                let mut f = [0.0; 2];
                f[axis] = level;
                let c = model.force_command(alpha_rad, f, k, false);
                c.joints
                    .iter()
                    .all(|j| j.limited.0 == 0 && j.pressure_bar.iter().all(|&p| p <= ceiling_bar))
            })
        })
    };
    // the share of the way, bisected down from 0.8 where a step would pass the ceiling
    let (mut ok, mut bad) = (0.0, 0.8);
    if within(at(bad)) {
        return at(bad);
    }
    for _ in 0..20 {
        let mid = 0.5 * (ok + bad);
        if within(at(mid)) {
            ok = mid;
        } else {
            bad = mid;
        }
    }
    at(ok)
}

/// §4.2's static trial: the centre and the eight points of a square of half-side
/// `half_side_m` around it, in the order the handle visits them.
pub fn static_points(centre: Vec2<f64>, half_side_m: f64) -> [Vec2<f64>; 9] {
    let h = half_side_m;
    let d = [
        [0.0, 0.0],
        [h, 0.0],
        [h, h],
        [0.0, h],
        [-h, h],
        [-h, 0.0],
        [-h, -h],
        [0.0, -h],
        [h, -h],
    ];
    d.map(|o| [centre[0] + o[0], centre[1] + o[1]])
}

/// §5.2's force levels on one axis, in order: up to +3 steps, down to −3, back to 0.
pub fn step_levels() -> [f64; 13] {
    let mut v = [0.0; 13];
    let mut i = 1;
    for k in 1..=3 {
        v[i] = k as f64 * STEP_N;
        i += 1;
    }
    for k in (-3..=2).rev() {
        v[i] = k as f64 * STEP_N;
        i += 1;
    }
    for k in -2..=0 {
        v[i] = k as f64 * STEP_N;
        i += 1;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_parse_by_name_and_the_step_sequence_returns_to_zero() {
        assert_eq!("high".parse::<StiffnessLevel>(), Ok(StiffnessLevel::High));
        assert_eq!(
            "medium".parse::<StiffnessLevel>(),
            Err(UnknownStiffnessLevel)
        );
        let s = step_levels();
        assert_eq!(s[0], 0.0);
        assert_eq!(s[12], 0.0);
        assert!((s[3] - 3.0 * STEP_N).abs() < 1e-12);
        assert!((s[9] + 3.0 * STEP_N).abs() < 1e-12);
        let p = static_points([0.1, 0.2], 0.04);
        assert_eq!(p[0], [0.1, 0.2]);
        assert_eq!(p[2], [0.14, 0.24000000000000002]);
    }

    #[test]
    fn the_step_tests_high_co_contraction_is_higher_and_clamps_no_step() {
        let model = RobotModel::<f64>::thesis();
        for pose_deg in crate::thesis::STEP_POSES_DEG {
            let alpha = pose_deg.map(f64::to_radians);
            let lo = step_test_stiffness_at(&model, alpha, StiffnessLevel::Low);
            let hi = step_test_stiffness_at(&model, alpha, StiffnessLevel::High);
            assert_eq!(lo, step_test_stiffness(&model, alpha));
            // each joint as stiff or stiffer, one at least a tenth stiffer
            assert!(
                (0..2).all(|j| hi[j] >= lo[j]) && (0..2).any(|j| hi[j] > 1.1 * lo[j]),
                "{pose_deg:?}: {lo:?} → {hi:?}"
            );
            let ceiling_bar = STEP_HIGH_PRESSURE_SHARE * model.params.pressure.max_bar;
            for axis in 0..2 {
                for level in step_levels() {
                    let mut f = [0.0; 2];
                    f[axis] = level;
                    let c = model.force_command(alpha, f, hi, false);
                    assert!(
                        c.joints.iter().all(|j| j.limited.0 == 0
                            && j.pressure_bar.iter().all(|&p| p <= ceiling_bar + 1e-9)),
                        "{pose_deg:?} {f:?} at {hi:?} is clamped or above {ceiling_bar} bar"
                    );
                }
            }
        }
    }
}
