//! Linear least squares for the stacked two-axis regressions (eq. 4.28, 4.30): each
//! parameter has a column on the X equation, the Y equation, or both. Solved through the
//! column-scaled normal equations with a symmetric eigen-decomposition (pseudo-inverse, so
//! a regressor that is identically zero or collinear gives a zero parameter instead of a
//! blow-up), and an active set for parameters that must stay positive.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;

/// One parameter's regressor: its contribution per unit parameter to the X and Y force.
/// The values are shared (`Arc`): the base model's columns go into every effect's fit, and
/// copying 90 000-sample vectors for each was a fifth of `diagnose`'s time.
#[derive(Clone, Debug)]
pub struct Column {
    pub name: String,
    pub axis: [Option<Arc<Vec<f64>>>; 2],
}

impl Column {
    pub fn both(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Column {
            name: name.into(),
            axis: [Some(Arc::new(x)), Some(Arc::new(y))],
        }
    }
    pub fn on(name: impl Into<String>, axis: usize, v: Vec<f64>) -> Self {
        let mut c = Column {
            name: name.into(),
            axis: [None, None],
        };
        c.axis[axis] = Some(Arc::new(v));
        c
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    // four accumulators: lets the compiler pipeline the sums (measured: eight, or exact
    // chunks, are no faster; the products are bound by the cache's bandwidth)
    let mut s = [0.0; 4];
    let chunks = a.len() / 4;
    for k in 0..chunks {
        let i = 4 * k;
        s[0] += a[i] * b[i];
        s[1] += a[i + 1] * b[i + 1];
        s[2] += a[i + 2] * b[i + 2];
        s[3] += a[i + 3] * b[i + 3];
    }
    let mut r = s[0] + s[1] + s[2] + s[3];
    for i in 4 * chunks..a.len() {
        r += a[i] * b[i];
    }
    r
}

/// Column products already computed, for fits that share columns (an effect's columns
/// against the base variants', which share their mass, damping and offset columns): keyed
/// by the two vectors' addresses and the rows. It holds a reference to every vector it has
/// keyed (a column's, or a shared target's), so no address is reused while it lives.
/// Measured: the shape ranking and the
/// cross-validation of a 90 s dynamic log computed each product up to six times (once per
/// shortlisted base variant), two fifths of `diagnose`'s time.
#[derive(Default)]
pub struct GramMemo {
    products: HashMap<(usize, usize, usize, usize), f64>,
    held: HashMap<usize, Arc<Vec<f64>>>,
}

impl GramMemo {
    fn product(&mut self, a: &Arc<Vec<f64>>, b: &Arc<Vec<f64>>, rows: &Range<usize>) -> f64 {
        let (pa, pb) = (Arc::as_ptr(a) as usize, Arc::as_ptr(b) as usize);
        let key = (pa.min(pb), pa.max(pb), rows.start, rows.end);
        if let Some(v) = self.products.get(&key) {
            return *v;
        }
        let v = dot(&a[rows.clone()], &b[rows.clone()]);
        self.products.insert(key, v);
        self.held.entry(pa).or_insert_with(|| a.clone());
        self.held.entry(pb).or_insert_with(|| b.clone());
        v
    }
}

/// Normal equations of the columns on rows `rows`.
pub struct Normal {
    pub gram: Vec<Vec<f64>>,
    pub rhs: Vec<f64>,
}

impl Normal {
    /// The normal equations of the first `k` columns (the top-left block).
    pub fn prefix(&self, k: usize) -> Normal {
        let k = k.min(self.rhs.len());
        Normal {
            gram: self.gram[..k].iter().map(|r| r[..k].to_vec()).collect(),
            rhs: self.rhs[..k].to_vec(),
        }
    }
}

pub fn normal_equations(cols: &[Column], target: &[&[f64]; 2], rows: Range<usize>) -> Normal {
    let empty = Normal {
        gram: Vec::new(),
        rhs: Vec::new(),
    };
    normal_equations_extended(&empty, cols, target, rows, &mut GramMemo::default())
}

/// Normal equations of `cols` whose first `known.rhs.len()` columns are those `known` was
/// computed from (same rows and target): only the new columns' products are computed. The
/// base model's columns are shared by every effect's fit; `memo` serves the products
/// already computed.
pub fn normal_equations_extended(
    known: &Normal,
    cols: &[Column],
    target: &[&[f64]; 2],
    rows: Range<usize>,
    memo: &mut GramMemo,
) -> Normal {
    let view = RowView::new(target, &rows);
    extend(&view, known, cols, memo, false)
}

/// [`normal_equations_extended`] for a target the memo may hold too: the right-hand sides
/// of columns that several fits share are then computed once as well. With `retarget` the
/// target is a new one (a delay shifts the measured force, not the regressors): the known
/// columns' Gram block is kept and every right-hand side computed against it.
pub fn normal_equations_shared_target(
    known: &Normal,
    cols: &[Column],
    target: &[Arc<Vec<f64>>; 2],
    rows: Range<usize>,
    memo: &mut GramMemo,
    retarget: bool,
) -> Normal {
    let view = RowView {
        range: rows.clone(),
        target: [&target[0][rows.clone()], &target[1][rows.clone()]],
        shared: Some([&target[0], &target[1]]),
    };
    extend(&view, known, cols, memo, retarget)
}

fn extend(
    view: &RowView,
    known: &Normal,
    cols: &[Column],
    memo: &mut GramMemo,
    retarget: bool,
) -> Normal {
    let p = cols.len();
    let nk = known.rhs.len().min(p);
    let mut gram = vec![vec![0.0; p]; p];
    let mut rhs = vec![0.0; p];
    for j in 0..nk {
        rhs[j] = if retarget {
            view.rhs(&cols[j], memo)
        } else {
            known.rhs[j]
        };
        gram[j][..nk].copy_from_slice(&known.gram[j][..nk]);
    }
    for j in nk..p {
        rhs[j] = view.rhs(&cols[j], memo);
        for k in 0..=j {
            let s = view.gram(&cols[j], &cols[k], memo);
            gram[j][k] = s;
            gram[k][j] = s;
        }
    }
    Normal { gram, rhs }
}

/// The rows a set of normal equations sums over, with the target there (and the target
/// itself when the memo may hold it).
struct RowView<'a> {
    range: Range<usize>,
    target: [&'a [f64]; 2],
    shared: Option<[&'a Arc<Vec<f64>>; 2]>,
}

impl<'a> RowView<'a> {
    fn new(target: &[&'a [f64]; 2], rows: &Range<usize>) -> Self {
        RowView {
            range: rows.clone(),
            target: target.map(|t| &t[rows.clone()]),
            shared: None,
        }
    }

    /// Σ column · target over both axes.
    fn rhs(&self, c: &Column, memo: &mut GramMemo) -> f64 {
        (0..2)
            .filter_map(|a| {
                let x = c.axis[a].as_ref()?;
                Some(match self.shared {
                    Some(t) => memo.product(x, t[a], &self.range),
                    None => dot(&x[self.range.clone()], self.target[a]),
                })
            })
            .sum()
    }

    /// Σ column_j · column_k over both axes.
    fn gram(&self, cj: &Column, ck: &Column, memo: &mut GramMemo) -> f64 {
        (0..2)
            .filter_map(|a| {
                let (x, y) = (cj.axis[a].as_ref()?, ck.axis[a].as_ref()?);
                Some(memo.product(x, y, &self.range))
            })
            .sum()
    }
}

/// Eigen-decomposition of a symmetric matrix (nalgebra's symmetric QR algorithm):
/// (eigenvalues, eigenvectors as columns). The fits solve their normal equations through it
/// as a pseudo-inverse with a relative eigenvalue cut-off, so collinear columns (an effect
/// that duplicates a base term) get the minimum-norm answer instead of a blow-up. Normal
/// equations rather than a QR of the rows: every effect's fit reuses the base columns'
/// cached Gram block, and only the new columns' products are computed.
pub fn symmetric_eigen(m: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = m.len();
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let a = nalgebra::DMatrix::from_fn(n, n, |i, j| 0.5 * (m[i][j] + m[j][i]));
    let e = a.symmetric_eigen();
    let vectors = (0..n)
        .map(|r| (0..n).map(|c| e.eigenvectors[(r, c)]).collect())
        .collect();
    (e.eigenvalues.iter().copied().collect(), vectors)
}

/// Solves the normal equations restricted to `active` parameters (others are zero).
fn solve_subset(n: &Normal, active: &[usize]) -> Vec<f64> {
    let p = n.rhs.len();
    let k = active.len();
    let mut out = vec![0.0; p];
    if k == 0 {
        return out;
    }
    // scale to unit diagonal so the eigenvalue cut-off is relative
    let scale: Vec<f64> = active
        .iter()
        .map(|&j| {
            let d = n.gram[j][j];
            if d > 0.0 {
                1.0 / d.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let g: Vec<Vec<f64>> = (0..k)
        .map(|r| {
            (0..k)
                .map(|c| n.gram[active[r]][active[c]] * scale[r] * scale[c])
                .collect()
        })
        .collect();
    let b: Vec<f64> = (0..k).map(|r| n.rhs[active[r]] * scale[r]).collect();
    let (vals, vecs) = symmetric_eigen(&g);
    let vmax = vals.iter().cloned().fold(0.0, f64::max);
    let mut z = vec![0.0; k];
    for e in 0..k {
        if vals[e] > vmax * 1e-12 {
            let proj: f64 = (0..k).map(|r| vecs[r][e] * b[r]).sum::<f64>() / vals[e];
            for r in 0..k {
                z[r] += vecs[r][e] * proj;
            }
        }
    }
    for r in 0..k {
        out[active[r]] = z[r] * scale[r];
    }
    out
}

/// Least squares with lower bounds: parameter `i` of `floors` kept ≥ its value, those in
/// `positive` ≥ 0. (θ = f + θ̃ with θ̃ ≥ 0 on the floored ones: the normal equations of θ̃
/// have the right-hand side X'y − X'X f.)
pub fn solve_bounded(n: &Normal, positive: &[usize], floors: &[(usize, f64)]) -> Vec<f64> {
    if floors.is_empty() {
        return solve(n, positive);
    }
    let p = n.rhs.len();
    let mut f = vec![0.0; p];
    for &(i, v) in floors {
        if i < p {
            f[i] = v;
        }
    }
    let rhs: Vec<f64> = (0..p)
        .map(|r| n.rhs[r] - (0..p).map(|c| n.gram[r][c] * f[c]).sum::<f64>())
        .collect();
    let shifted = Normal {
        gram: n.gram.clone(),
        rhs,
    };
    let mut pos = positive.to_vec();
    pos.extend(floors.iter().map(|x| x.0).filter(|i| !positive.contains(i)));
    let mut th = solve(&shifted, &pos);
    for (t, fi) in th.iter_mut().zip(&f) {
        *t += fi;
    }
    th
}

/// Least squares with the parameters listed in `positive` kept ≥ 0 (active set: a
/// parameter that comes out negative is fixed at zero and the rest refitted, as a linear
/// least-squares solver with bound constraints would).
pub fn solve(n: &Normal, positive: &[usize]) -> Vec<f64> {
    let p = n.rhs.len();
    let mut active: Vec<usize> = (0..p).collect();
    loop {
        let x = solve_subset(n, &active);
        let worst = positive
            .iter()
            .filter(|j| active.contains(j) && x[**j] < 0.0)
            .min_by(|a, b| x[**a].total_cmp(&x[**b]));
        match worst {
            Some(&j) => active.retain(|&a| a != j),
            None => return x,
        }
    }
}

/// Residual sum of squares from the normal equations: yᵀy − 2θᵀb + θᵀGθ.
pub fn rss(n: &Normal, yty: f64, theta: &[f64]) -> f64 {
    let p = theta.len();
    let mut q = 0.0;
    for i in 0..p {
        for j in 0..p {
            q += theta[i] * n.gram[i][j] * theta[j];
        }
    }
    yty - 2.0 * theta.iter().zip(&n.rhs).map(|(a, b)| a * b).sum::<f64>() + q
}

/// Prediction of the columns with parameters `theta` on all samples, per axis.
pub fn predict(cols: &[Column], theta: &[f64], len: usize) -> [Vec<f64>; 2] {
    let mut out = [vec![0.0; len], vec![0.0; len]];
    for (c, &th) in cols.iter().zip(theta) {
        if th == 0.0 {
            continue;
        }
        for a in 0..2 {
            if let Some(v) = &c.axis[a] {
                for (o, x) in out[a].iter_mut().zip(v.iter()) {
                    *o += th * x;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two fits that share columns through one memo: each product is computed once, and
    /// the normal equations are those computed without it, bit for bit.
    #[test]
    fn memo_serves_shared_products_unchanged() {
        let n = 500;
        let v = |f: f64| Arc::new((0..n).map(|i| (i as f64 * f).sin()).collect::<Vec<f64>>());
        let (shared, own_a, own_b, extra) = (v(0.01), v(0.02), v(0.03), v(0.05));
        let col = |name: &str, x: &Arc<Vec<f64>>| Column {
            name: name.into(),
            axis: [Some(x.clone()), None],
        };
        let target = [v(0.07), Arc::new(vec![0.0; n])];
        let fit_a = [col("s", &shared), col("a", &own_a), col("e", &extra)];
        let fit_b = [col("s", &shared), col("b", &own_b), col("e", &extra)];
        let empty = Normal {
            gram: Vec::new(),
            rhs: Vec::new(),
        };
        let mut memo = GramMemo::default();
        let rows = 10..450;
        for cols in [&fit_a, &fit_b] {
            let with = normal_equations_shared_target(
                &empty,
                cols,
                &target,
                rows.clone(),
                &mut memo,
                false,
            );
            let t = [target[0].as_slice(), target[1].as_slice()];
            let without = normal_equations(cols, &t, rows.clone());
            assert_eq!(with.gram, without.gram);
            assert_eq!(with.rhs, without.rhs);
        }
        // fit a: 6 products of its columns, 3 with the target; fit b adds its own column's
        // 3 products with the others and itself and 1 with the target
        assert_eq!(memo.products.len(), 6 + 3 + 3 + 1);
    }

    #[test]
    fn recovers_exact_parameters_and_handles_collinear_columns() {
        let n = 200;
        let x1: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
        let x2: Vec<f64> = (0..n).map(|i| (i as f64 * 0.037).cos()).collect();
        let y: Vec<f64> = (0..n).map(|i| 3.0 * x1[i] - 2.0 * x2[i]).collect();
        let zero = vec![0.0; n];
        let cols = vec![
            Column::on("a", 0, x1.clone()),
            Column::on("b", 0, x2.clone()),
            Column::on("dup", 0, zero.clone()),
        ];
        let ne = normal_equations(&cols, &[&y, &zero], 0..n);
        let th = solve(&ne, &[]);
        assert!((th[0] - 3.0).abs() < 1e-9 && (th[1] + 2.0).abs() < 1e-9 && th[2] == 0.0);
        // b constrained positive: it is dropped, a refitted alone
        let th = solve(&ne, &[1]);
        assert_eq!(th[1], 0.0);
        assert!(th[0] > 0.0);
    }
}
