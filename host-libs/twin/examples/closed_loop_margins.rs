//! Margins of the closed force loop (docs/closed-loop.md): the loop L(s) = C(s)·g·H(s)·e^(−sτ)
//! with C the designed PID (filtered derivative, `pam_control::ForceLoopConfig::designed`),
//! H the converters' second order (Table 5.2, `RobotParams::thesis().ip`), g the plant's
//! static gain as the loop sees it and τ the loop's delay (one period of computation plus
//! half a period of zero-order hold, plus any transport delay).
//!
//! ```sh
//! cargo run -p pam-twin --example closed_loop_margins [KI_SCALE [GAIN_SCALE]]
//! ```

use pam_control::ForceLoopConfig;
use pam_model::RobotParams;

#[derive(Clone, Copy)]
struct C(f64, f64);
impl C {
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
    fn arg(self) -> f64 {
        self.1.atan2(self.0)
    }
}

/// (gain margin, its frequency rad/s, phase margin °, crossover rad/s).
fn margins(
    cfg: &ForceLoopConfig,
    wn: f64,
    zeta: f64,
    g: f64,
    delay_s: f64,
) -> (f64, f64, f64, f64) {
    let (kp, ki, kd, wf) = (
        cfg.kp as f64,
        cfg.ki_per_s as f64,
        cfg.kd_s as f64,
        cfg.derivative_filter_rad_s as f64,
    );
    let l = |w: f64| {
        let s = C(0.0, w);
        let h = C(wn * wn, 0.0).div(
            s.mul(s)
                .add(C(2.0 * zeta * wn, 0.0).mul(s))
                .add(C(wn * wn, 0.0)),
        );
        let c = C(kp, 0.0)
            .add(C(ki, 0.0).div(s))
            .add(C(kd * wf, 0.0).mul(s).div(s.add(C(wf, 0.0))));
        let d = C((w * delay_s).cos(), -(w * delay_s).sin());
        c.mul(h).mul(d).mul(C(g, 0.0))
    };
    let (mut gm, mut w_gm, mut pm, mut w_c) = (f64::INFINITY, f64::NAN, f64::NAN, f64::NAN);
    let mut prev_phase = l(0.01).arg();
    let mut unwrap = 0.0;
    let mut prev_mag = l(0.01).abs();
    let n = 200_000;
    for i in 1..=n {
        let w = 0.01 * (1e6f64).powf(i as f64 / n as f64);
        let v = l(w);
        let mut ph = v.arg() + unwrap;
        while ph - prev_phase > std::f64::consts::PI {
            unwrap -= std::f64::consts::TAU;
            ph -= std::f64::consts::TAU;
        }
        while ph - prev_phase < -std::f64::consts::PI {
            unwrap += std::f64::consts::TAU;
            ph += std::f64::consts::TAU;
        }
        let pi = std::f64::consts::PI;
        if prev_phase > -pi && ph <= -pi && gm.is_infinite() {
            gm = 1.0 / v.abs();
            w_gm = w;
        }
        if prev_mag > 1.0 && v.abs() <= 1.0 && w_c.is_nan() {
            w_c = w;
            pm = (ph + pi).to_degrees();
        }
        prev_phase = ph;
        prev_mag = v.abs();
    }
    (gm, w_gm, pm, w_c)
}

fn main() {
    let p = RobotParams::<f64>::thesis();
    let mut cfg = ForceLoopConfig::designed();
    // an optional multiplier of the integral gain: the impedance mode runs it at
    // `IMPEDANCE_INTEGRAL_SCALE` (docs/impedance.md)
    if let Some(scale) = std::env::args().nth(1) {
        cfg.ki_per_s *= scale.parse::<f32>().expect("KI_SCALE, a number");
    }
    // and of all three: the force mode's against a compliant handle fall toward
    // `compliant_gain_scale` (docs/closed-loop.md, "A held handle")
    if let Some(scale) = std::env::args().nth(2) {
        let s = scale.parse::<f32>().expect("GAIN_SCALE, a number");
        cfg.kp *= s;
        cfg.ki_per_s *= s;
        cfg.kd_s *= s;
    }
    let (wn, zeta) = (p.ip.natural_freq_rad_s, p.ip.damping_ratio);
    println!("converters: ωn = {wn} rad/s, ζ = {zeta}; gains kp {} ki {} 1/s kd {} s, derivative filter {} rad/s", cfg.kp, cfg.ki_per_s, cfg.kd_s, cfg.derivative_filter_rad_s);
    println!("| plant gain g | delay τ | gain margin | at | phase margin | crossover |");
    println!("|---|---|---|---|---|---|");
    for (g, why) in [
        (1.0, "twin, model"),
        (0.43, "twin's lowest step gain"),
        (1.75, "twin with gain plane (1/0.57)"),
    ] {
        for delay_ms in [1.5, 10.0, 20.0, 41.5] {
            let (gm, wg, pm, wc) = margins(&cfg, wn, zeta, g, delay_ms * 1e-3);
            println!(
                "| {g} ({why}) | {delay_ms} ms | {:.1} ({:.1} dB) | {:.0} rad/s | {:.0}° | {:.1} rad/s |",
                gm,
                20.0 * gm.log10(),
                wg,
                pm,
                wc
            );
        }
    }
}
