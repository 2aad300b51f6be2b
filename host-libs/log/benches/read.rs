//! Reading speed of the strict v1 reader on a log the size of a long trial: 90 s at 1 kHz
//! with the required columns, the pressures and their commands (`cargo bench -p pam-log`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pam_log::{col, read_str, Log};
use std::hint::black_box;

fn trial_log() -> String {
    let mut columns: Vec<&str> = col::REQUIRED.to_vec();
    columns.extend(col::PRESSURES_BAR);
    columns.extend(col::PRESSURES_CMD_BAR);
    columns.push(col::SEQ);
    let mut log = Log::new(&columns);
    log.set_meta("experiment", "dynamic");
    let mut row = vec![0.0; columns.len()];
    for i in 0..90_000 {
        let t = i as f64 * 1e-3;
        for (k, v) in row.iter_mut().enumerate() {
            *v = (t * (1.0 + k as f64 * 0.37)).sin() * (1.0 + k as f64);
        }
        row[0] = t;
        row[columns.len() - 1] = i as f64;
        log.push_row(&row);
    }
    log.to_csv_string()
}

fn read(c: &mut Criterion) {
    let text = trial_log();
    let mut group = c.benchmark_group("read");
    group.sample_size(20);
    group.throughput(Throughput::Bytes(text.len() as u64));
    group.bench_function("90 s at 1 kHz, 18 columns", |b| {
        b.iter(|| read_str(black_box(&text), None).expect("a well-formed log"))
    });
    group.finish();
}

criterion_group!(benches, read);
criterion_main!(benches);
