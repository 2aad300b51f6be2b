//! Trace of one §5.2 force step at a pose (to see why a step is slow,
//! docs/closed-loop.md): every 10 ms the measured force, the closed loop's integral, the
//! commanded and true pressures, the twin's four muscle forces (a slack cable reads 0) and the
//! inverse model's `Limited` flags. The levels from 0 to FROM are stepped through first, 1.5 s
//! each, as the test does.
//!
//! ```sh
//! cargo run --release -p pam-twin --example step_trace -- POSE AXIS FROM TO [rig] [ff] [ol] [with:EFFECT]
//! # e.g. 7 0 18.2 27.3: the worst step before the taut-cable inverse
//! ```
//! `rig`: the identified rig; `ff`: the gain plane; `ol`: open loop instead of closed;
//! `with:EFFECT`: a twin effect (`pamctl sim --list-effects`), e.g. `with:asymmetric_ip_rates`.
use pam_control::{Controller, Mode, SafetyConfig, Sensors};
use pam_model::protocols::step_test_stiffness;
use pam_model::RobotModel;
use pam_twin::experiments::STEP_POSES_DEG;
use pam_twin::{HandleCondition, Twin, TwinConfig};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let pose: usize = a[0].parse().unwrap();
    let axis: usize = a[1].parse().unwrap();
    let from: f32 = a[2].parse().unwrap();
    let to: f32 = a[3].parse().unwrap();
    let rig = a.iter().any(|s| s == "rig");
    let ff = a.iter().any(|s| s == "ff");
    let mut tc = if rig {
        TwinConfig::identified_rig()
    } else {
        TwinConfig::thesis()
    };
    let effects: Vec<&str> = a.iter().filter_map(|s| s.strip_prefix("with:")).collect();
    tc.effects = pam_twin::EffectSet::parse_list(&effects).expect("an effect");
    let p = STEP_POSES_DEG[pose];
    let alpha = [p[0].to_radians(), p[1].to_radians()];
    tc.initial_alpha_rad = alpha;
    let params = tc.params;
    let model = RobotModel::new(params);
    let k = step_test_stiffness(&model, alpha);
    let mut twin = Twin::new(tc);
    let mut ctl = Controller::new(
        RobotModel::<f32>::new(params.cast()),
        SafetyConfig::default_1khz(),
    );
    let mut m = twin.step(1e-9, [4.0; 4], &HandleCondition::Blocked);
    ctl.arm().unwrap();
    let ol = a.iter().any(|s| s == "ol");
    let mode = |f: f32| {
        let mut fv = [0.0f32; 2];
        fv[axis] = f;
        if ol {
            return Mode::Force {
                force_n: fv,
                stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
                feed_forward: ff,
            };
        }
        Mode::ForceClosedLoop {
            force_n: fv,
            stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
            feed_forward: ff,
            gain_scale: 1.0,
        }
    };
    ctl.set_mode(mode(0.0)).unwrap();
    // 3 s at zero, then the levels 0 → from in 9.1 N steps of 1.5 s, then `to`
    let nlev = (from / 9.1).abs().round() as usize;
    let n_pre = 3000 + 1500 * nlev;
    for i in 0..(n_pre + 600) {
        if i >= 3000 && i < n_pre && (i - 3000) % 1500 == 0 {
            let l = (i - 3000) / 1500 + 1;
            ctl.set_mode(mode(from.signum() * 9.1 * l as f32)).unwrap();
        }
        if i == n_pre {
            ctl.set_mode(mode(to)).unwrap();
        }
        let s = Sensors {
            alpha_rad: [m.alpha_rad[0] as f32, m.alpha_rad[1] as f32],
            force_sensor_n: [m.force_sensor_n[0] as f32, m.force_sensor_n[1] as f32],
        };
        ctl.heartbeat();
        let out = ctl.step(&s);
        if (i >= n_pre && (i - n_pre).is_multiple_of(10)) || i + 1 == n_pre {
            let fl = ctl.force_loop();
            println!("{:4} g {:5.3} {} F {:7.2} {:7.2} I {:6.2} {:6.2} p {:5.2} {:5.2} {:5.2} {:5.2} | true {:5.2} {:5.2} {:5.2} {:5.2} mf {:?} lim {:?} ol {} st {:?} {:?}",
                i as i64 - n_pre as i64, fl.plant_gain(), fl.plant_gain_state().follows(), m.force_user_n[0], m.force_user_n[1], fl.integral_n()[0], fl.integral_n()[1],
                out.pressure_bar[0], out.pressure_bar[1], out.pressure_bar[2], out.pressure_bar[3],
                m.pressure_bar[0], m.pressure_bar[1], m.pressure_bar[2], m.pressure_bar[3], twin.state().muscle_force_n.map(|f| f.round()), out.limited, out.output_limited, out.state, out.faults);
        }
        let cur = out.current_ma.map(|c| c as f64);
        m = twin.step(0.001, cur, &HandleCondition::Blocked);
    }
}
