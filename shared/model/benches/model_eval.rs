//! Host timing of one full model evaluation for both joints (direct + inverse + limits),
//! the same workload the QEMU instruction count measures (`cargo xtask qemu-bench`).

use criterion::{criterion_group, criterion_main, Criterion};
use pam_model::checks::workload;
use pam_model::{Real, RobotModel};
use std::hint::black_box;

fn bench_type<R: Real>(c: &mut Criterion, name: &str) {
    let model = RobotModel::<R>::thesis();
    let inputs = workload::inputs::<R>();
    let mut i = 0usize;
    c.bench_function(name, |b| {
        b.iter(|| {
            let w = &inputs[i % inputs.len()];
            i += 1;
            black_box(model.evaluate(
                black_box(w.alpha_rad),
                black_box(w.torque_nm),
                black_box(w.stiffness_nm_per_rad),
            ))
        })
    });
}

fn benches(c: &mut Criterion) {
    bench_type::<f32>(c, "model_evaluate_both_joints_f32");
    bench_type::<f64>(c, "model_evaluate_both_joints_f64");
}

criterion_group!(model_eval, benches);
criterion_main!(model_eval);
