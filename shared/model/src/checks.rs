//! Self-checks of the model: the thesis's reference values and property sweeps.
//!
//! They are plain `no_std` functions so that the same code runs under `cargo test` on the
//! host (in f32 and f64) and on the emulated Cortex-M4F (`qemu-tests/`, in f32 and
//! soft-float f64). Each returns the first deviation it finds with the numbers involved.
//! Sweeps use a fixed-seed generator so a failure reproduces.
//!
//! Reference values: README, "Reproduced values" (`cargo run -p pam-model --example
//! reference_values` prints them). Where the thesis's printed
//! number does not follow from its equations, the check uses what the equations give and
//! the comment keeps the printed number.

use crate::ellipse::Ellipse;
use crate::joint::Limited;
use crate::mat2::Mat2;
use crate::params::RobotParams;
use crate::real::Real;
use crate::robot::RobotModel;

/// What a failed check found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Failure {
    pub what: &'static str,
    pub got: f64,
    pub expected: f64,
    pub tolerance: f64,
    /// Sample number within a sweep, or the table row.
    pub index: u32,
}

pub type CheckResult = Result<(), Failure>;

/// `Ok` when `ok`, else a failure named `what` (for yes/no facts).
pub fn holds_that(what: &'static str, ok: bool) -> CheckResult {
    holds(what, 0, ok)
}

/// `Ok` when `got` is finite and within `tolerance` of `expected`.
pub fn near_f32(what: &'static str, got: f32, expected: f32, tolerance: f32) -> CheckResult {
    close(what, 0, got as f64, expected as f64, tolerance as f64)
}

#[derive(Clone, Copy)]
pub struct Check {
    pub name: &'static str,
    pub run: fn() -> CheckResult,
}

/// Lists non-generic check functions as `pub const CHECKS: &[Check]` (run on the target by
/// the QEMU suite) and as one host `#[test]` each. Used by the crates above the model
/// (pam-control, pam-device); the model's own checks are generic over f32/f64.
#[macro_export]
macro_rules! register_checks {
    ($($name:ident),* $(,)?) => {
        pub const CHECKS: &[$crate::checks::Check] =
            &[$($crate::checks::Check { name: stringify!($name), run: $name }),*];
        #[cfg(test)]
        mod on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name() { panic!("{e:?}") } })*
        }
    };
}

fn close(what: &'static str, index: u32, got: f64, expected: f64, tolerance: f64) -> CheckResult {
    if (got - expected).abs() <= tolerance && got.is_finite() {
        Ok(())
    } else {
        Err(Failure {
            what,
            got,
            expected,
            tolerance,
            index,
        })
    }
}

fn holds(what: &'static str, index: u32, ok: bool) -> CheckResult {
    if ok {
        Ok(())
    } else {
        Err(Failure {
            what,
            got: 0.0,
            expected: 1.0,
            tolerance: 0.0,
            index,
        })
    }
}

/// Relative numerical tolerance of the scalar type (f32 runs get looser identity bounds).
fn num_tol<R: Real>() -> f64 {
    if core::mem::size_of::<R>() == 4 {
        1.0
    } else {
        1e-6
    }
}

/// xorshift64*: deterministic, tiny, good enough for test sweeps.
pub struct Rng(u64);
impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.max(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}

fn model<R: Real>() -> RobotModel<R> {
    RobotModel::new(RobotParams::thesis())
}

const SWEEP: u32 = 400;

// ---------------------------------------------------------------- reference values

/// ε0 = δl / (2 l0): 6.875 % and 6.375 % (Table 2.1 and eq. 2.8).
pub fn epsilon0_values<R: Real>() -> CheckResult {
    let m = model::<R>();
    close(
        "epsilon0 joint 1",
        1,
        m.joints[0].epsilon0.to_f64(),
        0.06875,
        1e-6,
    )?;
    close(
        "epsilon0 joint 2",
        2,
        m.joints[1].epsilon0.to_f64(),
        0.06375,
        1e-6,
    )
}

/// Anti-slack force of joint 2: F(ε0, 2.3 bar) = 134.59 N by Table 3.1 (thesis prints
/// 131.08 N). Tolerance 0.1 %.
pub fn anti_slack_force_joint2<R: Real>() -> CheckResult {
    let f = model::<R>().joints[1].anti_slack_force_n.to_f64();
    close("anti-slack force joint 2 [N]", 2, f, 134.59, 134.59e-3)
}

/// Anti-slack force of joint 1: 121.96 N by Table 3.1 (the printed 188.47 N does not follow
/// from Table 3.1). Tolerance 0.1 %.
pub fn anti_slack_force_joint1<R: Real>() -> CheckResult {
    let f = model::<R>().joints[0].anti_slack_force_n.to_f64();
    close("anti-slack force joint 1 [N]", 1, f, 121.96, 121.96e-3)
}

fn whole_range_torque<R: Real>(joint: usize, expected: f64, what: &'static str) -> CheckResult {
    let m = model::<R>();
    let range_deg = (m.joints[joint].alpha_max_rad - m.joints[joint].alpha_min_rad)
        .to_degrees()
        .to_f64();
    // 1° steps, as in §3.2
    let (lo, hi) = m.joints[joint].whole_range_torque_nm(&m.params.muscle, range_deg as u32);
    close(
        what,
        joint as u32 + 1,
        hi.to_f64(),
        expected,
        expected * 0.02,
    )?;
    close(
        what,
        joint as u32 + 1,
        lo.to_f64(),
        -expected,
        expected * 0.02,
    )
}

/// Torque reachable over the whole range, joint 1: ±31.95 N·m by the equations (thesis
/// prints ±31.5 N·m). Tolerance 2 %.
pub fn whole_range_torque_joint1<R: Real>() -> CheckResult {
    whole_range_torque::<R>(0, 31.95, "whole-range torque joint 1 [N m]")
}

/// Joint 2: ±22.31 N·m by the equations (thesis prints ±22 N·m). Tolerance 2 %.
pub fn whole_range_torque_joint2<R: Real>() -> CheckResult {
    whole_range_torque::<R>(1, 22.31, "whole-range torque joint 2 [N m]")
}

pub use crate::thesis::TABLE_4_1;

/// (K_low,1, K_high,1, K_low,2, K_high,2) at a pose given in degrees.
pub fn table_4_1_stiffness<R: Real>(alpha_deg: [f64; 2]) -> [f64; 4] {
    let m = model::<R>();
    let mut out = [0.0; 4];
    for j in 0..2 {
        let (lo, hi) = m
            .capability(j, R::from_f64(alpha_deg[j].to_radians()))
            .trial_stiffness_levels();
        out[2 * j] = lo.to_f64();
        out[2 * j + 1] = hi.to_f64();
    }
    out
}

/// All twenty stiffness values of Table 4.1 within 2.5 % of the printed value (joint 1's
/// K_low comes out about 1 N·m/rad under the print everywhere; still inside 2.5 %).
pub fn table_4_1_all_points<R: Real>() -> CheckResult {
    const WHAT: [&str; 4] = [
        "Table 4.1 K_low,1 [N m/rad]",
        "Table 4.1 K_high,1 [N m/rad]",
        "Table 4.1 K_low,2 [N m/rad]",
        "Table 4.1 K_high,2 [N m/rad]",
    ];
    for (row, (a1, a2, printed)) in TABLE_4_1.iter().enumerate() {
        let got = table_4_1_stiffness::<R>([*a1, *a2]);
        for k in 0..4 {
            close(
                WHAT[k],
                row as u32 + 1,
                got[k],
                printed[k],
                printed[k] * 0.025,
            )?;
        }
    }
    Ok(())
}

/// The handle at the neutral pose is at (0, √(L1² + L2²)) = (0, 0.8322 m) in the world
/// frame, and at the origin of the user frame.
pub fn neutral_handle_position<R: Real>() -> CheckResult {
    let k = model::<R>().kinematics;
    let w = k.forward_world([R::ZERO; 2]);
    close("neutral handle x [m]", 0, w[0].to_f64(), 0.0, 1e-6)?;
    close("neutral handle y [m]", 0, w[1].to_f64(), 0.83216, 1e-4)?;
    let u = k.forward_user([R::ZERO; 2]);
    close("neutral user x [m]", 0, u[0].to_f64(), 0.0, 1e-6)?;
    close("neutral user y [m]", 0, u[1].to_f64(), 0.0, 1e-6)
}

// ---------------------------------------------------------------- properties

fn random_alpha<R: Real>(m: &RobotModel<R>, rng: &mut Rng) -> [R; 2] {
    let mut a = [R::ZERO; 2];
    for j in 0..2 {
        a[j] = R::from_f64(rng.uniform(
            m.joints[j].alpha_min_rad.to_f64(),
            m.joints[j].alpha_max_rad.to_f64(),
        ));
    }
    a
}

/// Inverse ∘ direct is the identity inside the quadrilateral: any attainable (τ, K) comes
/// back unchanged and unflagged.
pub fn inverse_then_direct_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0001);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        for j in 0..2 {
            let cap = m.capability(j, alpha[j]);
            let (t_lo, t_hi) = cap.torque_limits_nm();
            // stay a hair inside so rounding cannot put the request on the wrong side
            let t = rng.uniform(t_lo.to_f64() * 0.999, t_hi.to_f64() * 0.999);
            let Some((k_lo, k_hi)) = cap.stiffness_range(R::from_f64(t)) else {
                return holds("stiffness range exists inside torque limits", i, false);
            };
            let span = (k_hi - k_lo).to_f64();
            let k = k_lo.to_f64() + span * rng.uniform(0.001, 0.999);
            let sol =
                m.joints[j].inverse(&m.params.muscle, alpha[j], R::from_f64(t), R::from_f64(k));
            holds("attainable request not flagged", i, sol.limited.is_none())?;
            let back = m.pose(j, alpha[j]);
            let tol = num_tol::<R>();
            close(
                "torque after inverse+direct [N m]",
                i,
                back.torque_nm(sol.pressure_bar).to_f64(),
                t,
                2e-3 * tol + 1e-9,
            )?;
            close(
                "stiffness after inverse+direct [N m/rad]",
                i,
                back.stiffness_nm_per_rad(sol.pressure_bar).to_f64(),
                k,
                2e-3 * tol + 1e-9,
            )?;
        }
    }
    Ok(())
}

/// Direct ∘ inverse is the identity on pressures: pressures inside the quadrilateral map
/// to (τ, K) and back to themselves.
pub fn direct_then_inverse_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0002);
    let mut tested = 0u32;
    for i in 0..SWEEP * 2 {
        let alpha = random_alpha(&m, &mut rng);
        let j = (i & 1) as usize;
        let p = [
            R::from_f64(rng.uniform(0.0, 5.0)),
            R::from_f64(rng.uniform(0.0, 5.0)),
        ];
        let pose = m.pose(j, alpha[j]);
        let (t, k) = (pose.torque_nm(p), pose.stiffness_nm_per_rad(p));
        let cap = pose.capability(&m.joints[j]);
        if !cap.contains(t, k) {
            continue; // pressure box corners outside the thesis's quadrilateral
        }
        tested += 1;
        let sol = m.joints[j].inverse(&m.params.muscle, alpha[j], t, k);
        let tol = 1e-4 * num_tol::<R>() + 1e-9;
        close(
            "P1 after direct+inverse [bar]",
            i,
            sol.pressure_bar[0].to_f64(),
            p[0].to_f64(),
            tol * 50.0,
        )?;
        close(
            "P2 after direct+inverse [bar]",
            i,
            sol.pressure_bar[1].to_f64(),
            p[1].to_f64(),
            tol * 50.0,
        )?;
    }
    holds(
        "enough samples inside the quadrilateral",
        tested,
        tested > SWEEP / 4,
    )
}

/// An unattainable request is clamped to the boundary and flagged, never passed through.
pub fn unattainable_requests_are_clamped_and_flagged<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0003);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let j = (i & 1) as usize;
        let cap = m.capability(j, alpha[j]);
        let (t_lo, t_hi) = cap.torque_limits_nm();
        // torque beyond the limit on a random side
        let beyond = if rng.uniform(0.0, 1.0) < 0.5 {
            t_hi * R::from_f64(1.5)
        } else {
            t_lo * R::from_f64(1.5)
        };
        let sol = m.joints[j].inverse(
            &m.params.muscle,
            alpha[j],
            beyond,
            cap.k_min.stiffness_nm_per_rad,
        );
        holds(
            "torque clamp flagged",
            i,
            sol.limited.contains(Limited::TORQUE),
        )?;
        let target = if beyond > R::ZERO { t_hi } else { t_lo };
        close(
            "clamped torque on the boundary [N m]",
            i,
            sol.torque_nm.to_f64(),
            target.to_f64(),
            1e-3 * num_tol::<R>() + 1e-7,
        )?;
        // stiffness beyond K_max at zero torque
        let sol = m.joints[j].inverse(
            &m.params.muscle,
            alpha[j],
            R::ZERO,
            cap.k_max.stiffness_nm_per_rad + R::from_f64(50.0),
        );
        holds(
            "stiffness clamp flagged",
            i,
            sol.limited.contains(Limited::STIFFNESS) && !sol.limited.contains(Limited::TORQUE),
        )?;
        close(
            "clamped stiffness at K_max [N m/rad]",
            i,
            sol.stiffness_nm_per_rad.to_f64(),
            cap.k_max.stiffness_nm_per_rad.to_f64(),
            1e-3 * num_tol::<R>() + 1e-7,
        )?;
        for p in sol.pressure_bar {
            holds(
                "clamped pressures within limits",
                i,
                p.to_f64() >= 0.0 && p.to_f64() <= 5.0,
            )?;
        }
    }
    Ok(())
}

/// NaN/∞ and out-of-range angles give the safe pretension, flagged, and finite pressures.
pub fn invalid_inputs_give_safe_pressures<R: Real>() -> CheckResult {
    let m = model::<R>();
    let nan = R::from_f64(f64::NAN);
    let inf = R::from_f64(f64::INFINITY);
    let cases: [(R, R, R); 5] = [
        (nan, R::ZERO, R::from_f64(60.0)),
        (R::ZERO, nan, R::from_f64(60.0)),
        (R::ZERO, R::ZERO, inf),
        (R::from_f64(1.0), R::ZERO, R::from_f64(60.0)), // 57°: outside ±22.5°
        (R::ZERO, -inf, nan),
    ];
    for (i, (a, t, k)) in cases.iter().enumerate() {
        let sol = m.joints[0].inverse(&m.params.muscle, *a, *t, *k);
        holds("invalid input flagged", i as u32, !sol.limited.is_none())?;
        for p in sol.pressure_bar {
            holds(
                "safe pressure finite and in limits",
                i as u32,
                p.is_finite() && p >= R::ZERO && p <= R::from_f64(5.0),
            )?;
        }
    }
    Ok(())
}

/// The quadrilateral's stiffness range at τ = 0 is [K_min, K_max], and its vertices are
/// the limit conditions of Table 3.2.
pub fn capability_vertices_match_table_3_2<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0004);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        for j in 0..2 {
            let cap = m.capability(j, alpha[j]);
            let Some((lo, hi)) = cap.stiffness_range(R::ZERO) else {
                return holds("zero torque attainable", i, false);
            };
            let tol = 1e-3 * num_tol::<R>() + 1e-9;
            close(
                "K range low at tau=0",
                i,
                lo.to_f64(),
                cap.k_min.stiffness_nm_per_rad.to_f64(),
                tol,
            )?;
            close(
                "K range high at tau=0",
                i,
                hi.to_f64(),
                cap.k_max.stiffness_nm_per_rad.to_f64(),
                tol,
            )?;
            close("tau at K_min", i, cap.k_min.torque_nm.to_f64(), 0.0, tol)?;
            close("tau at K_max", i, cap.k_max.torque_nm.to_f64(), 0.0, tol)?;
            let pmax = cap.k_max.pressure_bar[0]
                .max(cap.k_max.pressure_bar[1])
                .to_f64();
            close("one muscle at 5 bar for K_max", i, pmax, 5.0, 1e-4)?;
            close(
                "tau_max at P=(0,5)",
                i,
                cap.tau_max.pressure_bar[1].to_f64(),
                5.0,
                0.0,
            )?;
            holds(
                "K_min < K_max",
                i,
                cap.k_min.stiffness_nm_per_rad < cap.k_max.stiffness_nm_per_rad,
            )?;
            holds(
                "tau_min < 0 < tau_max",
                i,
                cap.tau_min.torque_nm < R::ZERO && cap.tau_max.torque_nm > R::ZERO,
            )?;
        }
    }
    Ok(())
}

/// FK ∘ IK is the identity in the workspace (user frame).
pub fn forward_then_inverse_kinematics_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0005);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let p = m.kinematics.forward_user(alpha);
        let Some(back) = m.kinematics.inverse_user(p) else {
            return holds("IK reaches an FK point", i, false);
        };
        let tol = 2e-4 * num_tol::<R>() + 1e-10;
        close(
            "alpha1 after FK+IK [rad]",
            i,
            back[0].to_f64(),
            alpha[0].to_f64(),
            tol,
        )?;
        close(
            "alpha2 after FK+IK [rad]",
            i,
            back[1].to_f64(),
            alpha[1].to_f64(),
            tol,
        )?;
        let again = m.kinematics.forward_user(back);
        close(
            "x after IK+FK [m]",
            i,
            again[0].to_f64(),
            p[0].to_f64(),
            1e-4 * num_tol::<R>() + 1e-10,
        )?;
        close(
            "y after IK+FK [m]",
            i,
            again[1].to_f64(),
            p[1].to_f64(),
            1e-4 * num_tol::<R>() + 1e-10,
        )?;
    }
    Ok(())
}

/// The Jacobian matches central finite differences of the forward kinematics.
pub fn jacobian_matches_finite_differences<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0006);
    // f32 needs a larger step: the round-off of x ≈ 0.8 m is ~6e-8 m
    let h = if num_tol::<R>() > 0.5 { 1e-3 } else { 1e-6 };
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let jac = m.kinematics.jacobian(alpha);
        for col in 0..2 {
            let mut ap = alpha;
            let mut am = alpha;
            ap[col] += R::from_f64(h);
            am[col] -= R::from_f64(h);
            let fp = m.kinematics.forward_world(ap);
            let fm = m.kinematics.forward_world(am);
            for row in 0..2 {
                let fd = (fp[row] - fm[row]).to_f64() / (2.0 * h);
                close(
                    "Jacobian vs finite difference [m/rad]",
                    i,
                    jac.0[row][col].to_f64(),
                    fd,
                    2e-4 * num_tol::<R>() + 1e-8,
                )?;
            }
        }
    }
    Ok(())
}

/// τ = Jᵀ F agrees with virtual work: F·δx = τ·δα for a small joint motion.
pub fn joint_torques_satisfy_virtual_work<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0007);
    let h = if num_tol::<R>() > 0.5 { 1e-3 } else { 1e-6 };
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-30.0, 30.0)),
            R::from_f64(rng.uniform(-30.0, 30.0)),
        ];
        let tau = m.kinematics.joint_torques(alpha, f);
        let d = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        let a1 = [
            alpha[0] + R::from_f64(d[0] * h),
            alpha[1] + R::from_f64(d[1] * h),
        ];
        let a0 = [
            alpha[0] - R::from_f64(d[0] * h),
            alpha[1] - R::from_f64(d[1] * h),
        ];
        let (x1, x0) = (
            m.kinematics.forward_world(a1),
            m.kinematics.forward_world(a0),
        );
        let work_cart = (f[0] * (x1[0] - x0[0]) + f[1] * (x1[1] - x0[1])).to_f64();
        let work_joint = tau[0].to_f64() * 2.0 * d[0] * h + tau[1].to_f64() * 2.0 * d[1] * h;
        close(
            "virtual work F.dx vs tau.dalpha [J]",
            i,
            work_cart,
            work_joint,
            60.0 * h * (1e-3 * num_tol::<R>() + 1e-8),
        )?;
    }
    Ok(())
}

/// The ellipse of R(φ)·diag(a, b)·R(φ)ᵀ returns φ (mod π) and the eigenvalues a, b.
pub fn ellipse_of_rotated_diagonal<R: Real>() -> CheckResult {
    let mut rng = Rng::new(0x5eed_0008);
    for i in 0..SWEEP {
        let big = rng.uniform(50.0, 600.0);
        let small = big * rng.uniform(0.05, 0.9);
        let phi = rng.uniform(-1.5, 1.5);
        let r = Mat2::<R>::rotation(R::from_f64(phi));
        let m = Mat2::diag(R::from_f64(big), R::from_f64(small)).congruence(&r.transpose());
        let e = Ellipse::of(&m);
        let tol = 1e-4 * num_tol::<R>() + 1e-9;
        close(
            "ellipse lambda_max",
            i,
            e.lambda_max.to_f64(),
            big,
            big * tol,
        )?;
        close(
            "ellipse lambda_min",
            i,
            e.lambda_min.to_f64(),
            small,
            big * tol,
        )?;
        close(
            "ellipse area",
            i,
            e.area.to_f64(),
            core::f64::consts::PI * big * small,
            core::f64::consts::PI * big * small * 10.0 * tol,
        )?;
        close(
            "ellipse aspect ratio",
            i,
            e.aspect_ratio.to_f64(),
            big / small,
            big / small * 100.0 * tol,
        )?;
        let mut d = e.orientation_rad.to_f64() - phi;
        while d > core::f64::consts::FRAC_PI_2 {
            d -= core::f64::consts::PI;
        }
        while d < -core::f64::consts::FRAC_PI_2 {
            d += core::f64::consts::PI;
        }
        close(
            "ellipse orientation (mod pi) [rad]",
            i,
            d,
            0.0,
            10.0 * tol / (1.0 - small / big),
        )?;
    }
    Ok(())
}

/// Joint → Cartesian → joint round trip (eq. 4.13 and its inverse), and the Cartesian
/// stiffness at point 1 has the thesis's structure (positive diagonal, coupled).
pub fn cartesian_stiffness_round_trip<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0009);
    for i in 0..SWEEP / 2 {
        let alpha = random_alpha(&m, &mut rng);
        let kj = [
            R::from_f64(rng.uniform(50.0, 150.0)),
            R::from_f64(rng.uniform(20.0, 70.0)),
        ];
        let Some(kc) = m.cartesian_stiffness(alpha, kj) else {
            return holds("Jacobian invertible in the workspace", i, false);
        };
        let back = crate::cartesian::cartesian_to_joint(&m.kinematics.jacobian(alpha), &kc);
        let tol = 1e-3 * num_tol::<R>() + 1e-9;
        close(
            "K_j11 after round trip",
            i,
            back.0[0][0].to_f64(),
            kj[0].to_f64(),
            kj[0].to_f64() * tol,
        )?;
        close(
            "K_j22 after round trip",
            i,
            back.0[1][1].to_f64(),
            kj[1].to_f64(),
            kj[1].to_f64() * tol,
        )?;
        close(
            "K_j12 after round trip",
            i,
            back.0[0][1].to_f64(),
            0.0,
            kj[0].to_f64() * tol,
        )?;
        holds(
            "Cartesian stiffness symmetric",
            i,
            (kc.0[0][1] - kc.0[1][0]).abs().to_f64() <= kc.0[0][0].abs().to_f64() * tol,
        )?;
    }
    Ok(())
}

/// The load-cell frame is the end-effector frame rotated by θ1 + θ2: a round trip is the
/// identity and, at the neutral pose, the rotation is α0 = atan(L2/L1).
pub fn load_cell_rotation<R: Real>() -> CheckResult {
    let m = model::<R>();
    let k = &m.kinematics;
    let u = k.sensor_to_user([R::ZERO; 2], [R::ONE, R::ZERO]);
    let alpha0 = libm::atan(0.45f64 / 0.70);
    close(
        "sensor X at neutral, user x",
        0,
        u[0].to_f64(),
        libm::cos(alpha0),
        1e-6,
    )?;
    close(
        "sensor X at neutral, user y",
        0,
        u[1].to_f64(),
        libm::sin(alpha0),
        1e-6,
    )?;
    let mut rng = Rng::new(0x5eed_000a);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-50.0, 50.0)),
            R::from_f64(rng.uniform(-50.0, 50.0)),
        ];
        let back = k.sensor_to_user(alpha, k.user_to_sensor(alpha, f));
        close(
            "force after user->sensor->user [N]",
            i,
            back[0].to_f64(),
            f[0].to_f64(),
            1e-4 * num_tol::<R>() + 1e-9,
        )?;
        close(
            "force after user->sensor->user [N]",
            i,
            back[1].to_f64(),
            f[1].to_f64(),
            1e-4 * num_tol::<R>() + 1e-9,
        )?;
    }
    Ok(())
}

/// I/P law (eq. 2.2) both ways, saturation at the 4–20 mA ends, and load-cell law (eq. 2.1).
pub fn signal_laws<R: Real>() -> CheckResult {
    let p = RobotParams::<R>::thesis();
    let c = p.ip.current_for(R::from_f64(2.3));
    close(
        "current for 2.3 bar [mA]",
        0,
        c.current_ma.to_f64(),
        (2.3 + 1.63) / 0.32667,
        1e-4,
    )?;
    holds("2.3 bar not saturated", 0, !c.saturated)?;
    close(
        "pressure back from current [bar]",
        0,
        c.pressure_bar.to_f64(),
        2.3,
        1e-4,
    )?;
    let hi = p.ip.current_for(R::from_f64(5.0));
    holds("5 bar saturates the 20 mA end", 1, hi.saturated)?;
    close(
        "current at the top [mA]",
        1,
        hi.current_ma.to_f64(),
        20.0,
        0.0,
    )?;
    close(
        "highest commandable pressure [bar]",
        1,
        hi.pressure_bar.to_f64(),
        0.32667 * 20.0 - 1.63,
        1e-4,
    )?;
    let nan = p.ip.current_for(R::from_f64(f64::NAN));
    close(
        "NaN pressure gives the minimum current [mA]",
        2,
        nan.current_ma.to_f64(),
        4.0,
        0.0,
    )?;
    let f = p.load_cell.forces_n([R::from_f64(0.9), R::from_f64(-0.6)]);
    close("load cell X [N]", 3, f[0].to_f64(), 10.0, 1e-4)?;
    close("load cell Z [N]", 3, f[1].to_f64(), -10.0, 1e-4)
}

/// Gain plane: G = p1 α1 + p2 α2 + p3; the corrected command times G is the request; a
/// gain under the floor is raised and flagged.
pub fn gain_plane_correction<R: Real>() -> CheckResult {
    let mut p = RobotParams::<R>::thesis();
    p.gain_plane.coeffs = [
        [R::from_f64(0.3), R::from_f64(-0.2), R::from_f64(0.6)],
        [R::from_f64(-0.1), R::from_f64(0.25), R::from_f64(0.5)],
    ];
    let alpha = [R::from_f64(0.2), R::from_f64(-0.3)];
    let g = [
        p.gain_plane.gain(0, alpha).to_f64(),
        p.gain_plane.gain(1, alpha).to_f64(),
    ];
    close("G_x", 0, g[0], 0.3 * 0.2 + 0.2 * 0.3 + 0.6, 1e-6)?;
    close("G_y", 0, g[1], -0.1 * 0.2 - 0.25 * 0.3 + 0.5, 1e-6)?;
    let (cmd, limited) = p
        .gain_plane
        .correct([R::from_f64(9.1), R::from_f64(-18.2)], alpha);
    holds("not limited", 0, !limited)?;
    close("corrected X times G", 0, cmd[0].to_f64() * g[0], 9.1, 1e-5)?;
    close(
        "corrected Y times G",
        0,
        cmd[1].to_f64() * g[1],
        -18.2,
        1e-5,
    )?;
    p.gain_plane.coeffs[0] = [R::ZERO, R::ZERO, R::from_f64(0.01)];
    let (cmd, limited) = p.gain_plane.correct([R::from_f64(9.1), R::ZERO], alpha);
    holds("tiny gain flagged", 1, limited)?;
    close("tiny gain floored", 1, cmd[0].to_f64(), 9.1 / 0.2, 1e-4)
}

/// Joint 1's permuted numbering: the channel map is applied once and inverts exactly.
pub fn channel_map_round_trip<R: Real>() -> CheckResult {
    let m = model::<R>();
    let jp = [
        [R::from_f64(1.0), R::from_f64(2.0)],
        [R::from_f64(3.0), R::from_f64(4.0)],
    ];
    let ch = m.channel_pressures_bar(jp);
    // joint 1's model muscle 1 drives channel 1, muscle 2 channel 0 (§2.3)
    close("channel 0 = joint 1 muscle 2", 0, ch[0].to_f64(), 2.0, 0.0)?;
    close("channel 1 = joint 1 muscle 1", 1, ch[1].to_f64(), 1.0, 0.0)?;
    close("channel 2 = joint 2 muscle 1", 2, ch[2].to_f64(), 3.0, 0.0)?;
    close("channel 3 = joint 2 muscle 2", 3, ch[3].to_f64(), 4.0, 0.0)?;
    holds("channel map inverts", 4, m.joint_pressures_bar(ch) == jp)?;
    holds("thesis parameters validate", 5, m.params.validate().is_ok())
}

/// The Cartesian force mode reproduces the requested force at the handle: the joint
/// torques it commands are Jᵀ F and the model's torques from its pressures match them.
pub fn force_mode_reproduces_force<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_000b);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-20.0, 20.0)),
            R::from_f64(rng.uniform(-20.0, 20.0)),
        ];
        let k = [R::from_f64(200.0), R::from_f64(80.0)]; // above K_min everywhere: clamps to the range
        let cmd = m.force_command(alpha, f, k, false);
        for j in 0..2 {
            let sol = &cmd.joints[j];
            if sol.limited.contains(Limited::TORQUE) {
                continue;
            }
            close(
                "torque delivered for force request [N m]",
                i,
                sol.torque_nm.to_f64(),
                cmd.joint_torque_nm[j].to_f64(),
                1e-3 * num_tol::<R>() + 1e-8,
            )?;
        }
    }
    Ok(())
}

/// The scalar's sin/cos against f64 libm over ±2π (for f32 this is the crate's own
/// sincos; under the `micromath` feature it is micromath's, which does not pass).
pub fn sin_cos_accuracy<R: Real>() -> CheckResult {
    let tol = 1e-7 * num_tol::<R>() + 1e-15;
    for i in 0..4001u32 {
        let x = -2.0 * core::f64::consts::PI + 4.0 * core::f64::consts::PI * i as f64 / 4000.0;
        let xr = R::from_f64(x);
        let exact_x = xr.to_f64(); // compare at the argument the type can hold
        let (s, c) = xr.sin_cos();
        close("sin", i, s.to_f64(), libm::sin(exact_x), tol)?;
        close("cos", i, c.to_f64(), libm::cos(exact_x), tol)?;
    }
    Ok(())
}

macro_rules! register_checks {
    ($($name:ident),* $(,)?) => {
        /// Every check, instantiated for f32 (the target's type).
        pub const CHECKS_F32: &[Check] = &[$(Check { name: stringify!($name), run: $name::<f32> }),*];
        /// Every check, instantiated for f64 (the host reference).
        pub const CHECKS_F64: &[Check] = &[$(Check { name: stringify!($name), run: $name::<f64> }),*];

        #[cfg(test)]
        mod f32_on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name::<f32>() { panic!("{e:?}") } })*
        }
        #[cfg(test)]
        mod f64_on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name::<f64>() { panic!("{e:?}") } })*
        }
    };
}

register_checks!(
    epsilon0_values,
    anti_slack_force_joint1,
    anti_slack_force_joint2,
    whole_range_torque_joint1,
    whole_range_torque_joint2,
    table_4_1_all_points,
    neutral_handle_position,
    inverse_then_direct_is_identity,
    direct_then_inverse_is_identity,
    unattainable_requests_are_clamped_and_flagged,
    invalid_inputs_give_safe_pressures,
    capability_vertices_match_table_3_2,
    forward_then_inverse_kinematics_is_identity,
    jacobian_matches_finite_differences,
    joint_torques_satisfy_virtual_work,
    ellipse_of_rotated_diagonal,
    cartesian_stiffness_round_trip,
    load_cell_rotation,
    signal_laws,
    gain_plane_correction,
    channel_map_round_trip,
    force_mode_reproduces_force,
    sin_cos_accuracy,
);

/// The benchmark workload shared by criterion (host) and the QEMU instruction count:
/// poses spread over the workspace with requests inside, on and outside the limits.
pub mod workload {
    use super::Rng;
    use crate::real::Real;

    pub const LEN: usize = 64;

    #[derive(Clone, Copy, Debug)]
    pub struct Input<R> {
        pub alpha_rad: [R; 2],
        pub torque_nm: [R; 2],
        pub stiffness_nm_per_rad: [R; 2],
    }

    pub fn inputs<R: Real>() -> [Input<R>; LEN] {
        let mut rng = Rng::new(0xbe_7c4);
        let mut out = [Input {
            alpha_rad: [R::ZERO; 2],
            torque_nm: [R::ZERO; 2],
            stiffness_nm_per_rad: [R::ZERO; 2],
        }; LEN];
        for w in out.iter_mut() {
            let f = |x: f64| R::from_f64(x);
            w.alpha_rad = [f(rng.uniform(-0.39, 0.39)), f(rng.uniform(-0.56, 0.56))];
            w.torque_nm = [f(rng.uniform(-40.0, 40.0)), f(rng.uniform(-28.0, 28.0))];
            w.stiffness_nm_per_rad = [f(rng.uniform(40.0, 160.0)), f(rng.uniform(15.0, 75.0))];
        }
        out
    }
}

/// Largest differences between the f32 model and the f64 reference over a grid of poses
/// and requests. Run on the target, the f64 side is soft-float and bit-identical to the
/// host's f64.
pub mod precision {
    use super::{workload, Rng};
    use crate::robot::RobotModel;

    #[derive(Clone, Copy, Debug, Default)]
    pub struct Quantity {
        pub name: &'static str,
        pub unit: &'static str,
        pub max_abs: f64,
        pub max_rel: f64,
        pub samples: u32,
    }

    impl Quantity {
        fn new(name: &'static str, unit: &'static str) -> Self {
            Quantity {
                name,
                unit,
                ..Default::default()
            }
        }
        fn add(&mut self, single: f32, double: f64) {
            let d = (single as f64 - double).abs();
            let rel = d / double.abs().max(1e-12);
            if d > self.max_abs || !d.is_finite() {
                self.max_abs = d;
            }
            if rel > self.max_rel {
                self.max_rel = rel;
            }
            self.samples += 1;
        }
    }

    pub const N: usize = 8;

    pub fn compare() -> [Quantity; N] {
        let m32 = RobotModel::<f32>::thesis();
        let m64 = RobotModel::<f64>::thesis();
        let mut q = [
            Quantity::new("muscle force", "N"),
            Quantity::new("joint torque (direct)", "N m"),
            Quantity::new("joint stiffness (direct)", "N m/rad"),
            Quantity::new("capability tau_max/K_min/K_max", "-"),
            Quantity::new("inverse model pressures", "bar"),
            Quantity::new("handle position (FK)", "m"),
            Quantity::new("Jacobian entries", "m/rad"),
            Quantity::new("load cell rotation", "N"),
        ];
        let mut rng = Rng::new(0x9e37_79b9);
        for _ in 0..200 {
            let a = [rng.uniform(-0.39, 0.39), rng.uniform(-0.56, 0.56)];
            let p = [
                [rng.uniform(0.0, 5.0), rng.uniform(0.0, 5.0)],
                [rng.uniform(0.0, 5.0), rng.uniform(0.0, 5.0)],
            ];
            let a32 = [a[0] as f32, a[1] as f32];
            let p32 = p.map(|r| r.map(|x| x as f32));
            for j in 0..2 {
                let (s, d) = (m32.pose(j, a32[j]), m64.pose(j, a[j]));
                for k in 0..2 {
                    q[0].add(s.forces_n(p32[j])[k], d.forces_n(p[j])[k]);
                }
                q[1].add(s.torque_nm(p32[j]), d.torque_nm(p[j]));
                q[2].add(s.stiffness_nm_per_rad(p32[j]), d.stiffness_nm_per_rad(p[j]));
                let (c32, c64) = (s.capability(&m32.joints[j]), d.capability(&m64.joints[j]));
                q[3].add(c32.tau_max.torque_nm, c64.tau_max.torque_nm);
                q[3].add(
                    c32.k_min.stiffness_nm_per_rad,
                    c64.k_min.stiffness_nm_per_rad,
                );
                q[3].add(
                    c32.k_max.stiffness_nm_per_rad,
                    c64.k_max.stiffness_nm_per_rad,
                );
            }
            let x32 = m32.kinematics.forward_user(a32);
            let x64 = m64.kinematics.forward_user(a);
            q[5].add(x32[0], x64[0]);
            q[5].add(x32[1], x64[1]);
            let (j32, j64) = (m32.kinematics.jacobian(a32), m64.kinematics.jacobian(a));
            for r in 0..2 {
                for c in 0..2 {
                    q[6].add(j32.0[r][c], j64.0[r][c]);
                }
            }
            let f = [rng.uniform(-40.0, 40.0), rng.uniform(-40.0, 40.0)];
            let r32 = m32
                .kinematics
                .sensor_to_user(a32, [f[0] as f32, f[1] as f32]);
            let r64 = m64.kinematics.sensor_to_user(a, f);
            q[7].add(r32[0], r64[0]);
            q[7].add(r32[1], r64[1]);
        }
        let w32 = workload::inputs::<f32>();
        let w64 = workload::inputs::<f64>();
        for (a, b) in w32.iter().zip(w64.iter()) {
            let s = m32.evaluate(a.alpha_rad, a.torque_nm, a.stiffness_nm_per_rad);
            let d = m64.evaluate(b.alpha_rad, b.torque_nm, b.stiffness_nm_per_rad);
            for j in 0..2 {
                for k in 0..2 {
                    q[4].add(s[j].solution.pressure_bar[k], d[j].solution.pressure_bar[k]);
                }
            }
        }
        q
    }
}
