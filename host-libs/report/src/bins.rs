//! Where the residual is: binned over the workspace, over velocity, per step.

/// Values on a grid of cells: `values[iy * nx + ix]`, `None` for an empty cell.
pub struct Grid {
    pub x_edges: Vec<f64>,
    pub y_edges: Vec<f64>,
    pub values: Vec<Option<f64>>,
}

/// The `q`-quantile of the finite values (linear between order statistics).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    s.sort_by(f64::total_cmp);
    let p = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (i, u) = (p.floor() as usize, p - p.floor());
    s[i] + u * (s[(i + 1).min(s.len() - 1)] - s[i])
}

fn edges(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect()
}

fn cell(v: f64, e: &[f64]) -> Option<usize> {
    let (lo, hi) = (e[0], *e.last()?);
    if !(v >= lo && v <= hi) {
        return None;
    }
    let n = e.len() - 1;
    Some((((v - lo) / (hi - lo) * n as f64) as usize).min(n - 1))
}

/// The handle's square bins: `n` cells along the longer side of the central 99 % of the
/// positions (cells of equal size in x and y).
pub fn workspace_edges(x: &[f64], y: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let (x0, x1) = (quantile(x, 0.005), quantile(x, 0.995));
    let (y0, y1) = (quantile(y, 0.005), quantile(y, 0.995));
    let side = ((x1 - x0).max(y1 - y0) / n as f64).max(1e-9);
    let nx = (((x1 - x0) / side).ceil() as usize).clamp(1, n);
    let ny = (((y1 - y0) / side).ceil() as usize).clamp(1, n);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (
        edges(cx - side * nx as f64 / 2.0, cx + side * nx as f64 / 2.0, nx),
        edges(cy - side * ny as f64 / 2.0, cy + side * ny as f64 / 2.0, ny),
    )
}

/// RMS of `mag` in each cell with at least `min_count` samples.
pub fn grid_rms(
    x: &[f64],
    y: &[f64],
    mag: &[f64],
    e: &(Vec<f64>, Vec<f64>),
    min_count: usize,
) -> Grid {
    let (nx, ny) = (e.0.len() - 1, e.1.len() - 1);
    let mut sum = vec![0.0; nx * ny];
    let mut cnt = vec![0usize; nx * ny];
    for i in 0..x.len().min(y.len()).min(mag.len()) {
        if let (Some(ix), Some(iy)) = (cell(x[i], &e.0), cell(y[i], &e.1)) {
            if mag[i].is_finite() {
                sum[iy * nx + ix] += mag[i] * mag[i];
                cnt[iy * nx + ix] += 1;
            }
        }
    }
    Grid {
        x_edges: e.0.clone(),
        y_edges: e.1.clone(),
        values: sum
            .iter()
            .zip(&cnt)
            .map(|(s, &c)| (c >= min_count.max(1)).then(|| (s / c as f64).sqrt()))
            .collect(),
    }
}

/// Per bin of a variable: its centre, the residual's mean and RMS, the sample count.
#[derive(Clone, Debug, PartialEq)]
pub struct Binned {
    pub center: Vec<f64>,
    pub mean: Vec<f64>,
    pub rms: Vec<f64>,
    pub count: Vec<usize>,
}

/// `n` equal bins over the central 99 % of `v`; bins with fewer than `min_count` samples
/// are NaN (a gap in the plot).
pub fn by_variable(v: &[f64], r: &[f64], n: usize, min_count: usize) -> Binned {
    let (lo, hi) = (quantile(v, 0.005), quantile(v, 0.995));
    let e = if hi > lo {
        edges(lo, hi, n)
    } else {
        edges(lo - 1e-9, lo + 1e-9, 1)
    };
    let nb = e.len() - 1;
    let (mut s, mut s2, mut c) = (vec![0.0; nb], vec![0.0; nb], vec![0usize; nb]);
    for (x, y) in v.iter().zip(r) {
        if let Some(k) = cell(*x, &e) {
            if y.is_finite() {
                s[k] += y;
                s2[k] += y * y;
                c[k] += 1;
            }
        }
    }
    let ok = |k: usize| c[k] >= min_count.max(1);
    Binned {
        center: (0..nb).map(|k| (e[k] + e[k + 1]) / 2.0).collect(),
        mean: (0..nb)
            .map(|k| if ok(k) { s[k] / c[k] as f64 } else { f64::NAN })
            .collect(),
        rms: (0..nb)
            .map(|k| {
                if ok(k) {
                    (s2[k] / c[k] as f64).sqrt()
                } else {
                    f64::NAN
                }
            })
            .collect(),
        count: c,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workspace_cells_are_square_and_rms_per_cell() {
        let x = [0.0, 0.01, 0.02, 0.04, 0.04];
        let y = [0.0, 0.0, 0.01, 0.02, 0.02];
        let e = workspace_edges(&x, &y, 4);
        let dx = e.0[1] - e.0[0];
        let dy = e.1[1] - e.1[0];
        assert!((dx - dy).abs() < 1e-12);
        assert_eq!(e.0.len(), 5);
        assert!(e.1.len() <= 5);
        let g = grid_rms(&x, &y, &[1.0, 1.0, 1.0, 3.0, 4.0], &e, 1);
        let top = g.values.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        assert!((top - 12.5f64.sqrt()).abs() < 1e-12, "{:?}", g.values);
        assert!(g.values.iter().any(|v| v.is_none()));
    }

    #[test]
    fn velocity_bins_show_a_sign_jump() {
        let v: Vec<f64> = (0..2000).map(|i| -1.0 + i as f64 / 1000.0).collect();
        let r: Vec<f64> = v.iter().map(|v| 2.0 * v.signum()).collect();
        let b = by_variable(&v, &r, 10, 5);
        assert_eq!(b.center.len(), 10);
        assert!((b.mean[0] + 2.0).abs() < 1e-12 && (b.mean[9] - 2.0).abs() < 1e-12);
        assert!(b.rms.iter().all(|r| (r - 2.0).abs() < 1e-12));
        let b = by_variable(&v, &r, 10, 100_000);
        assert!(b.mean.iter().all(|m| m.is_nan()));
    }
}
