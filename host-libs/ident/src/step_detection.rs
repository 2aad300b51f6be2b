//! Where the steps of a step trial are: jumps of the force reference (§5.3). Data
//! preparation: the held-out rows and the step identification both start from it.

/// Steps of the reference (or of the measured force when there is no reference):
/// |ΔF| > `threshold_n` between consecutive samples starts a new step (§5.3).
pub fn detect_steps(signal: &[f64], threshold_n: f64) -> Vec<usize> {
    let mut starts = vec![0];
    for i in 1..signal.len() {
        if (signal[i] - signal[i - 1]).abs() > threshold_n {
            // a step spread over consecutive samples counts once
            if i - *starts.last().unwrap() > 1 {
                starts.push(i);
            } else {
                *starts.last_mut().unwrap() = i;
            }
        }
    }
    starts
}

/// A step of the reference: samples `start..end`, the axis whose reference jumped most.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceStep {
    pub start: usize,
    pub end: usize,
    pub axis: usize,
}

/// The steps of a two-axis reference: a jump larger than `threshold` on either axis starts
/// a step (jumps on consecutive samples count once), which lasts until the next.
pub fn reference_steps(reference: &[Vec<f64>; 2], threshold: f64) -> Vec<ReferenceStep> {
    let n = reference[0].len().min(reference[1].len());
    let mut starts: Vec<(usize, usize)> = Vec::new();
    for i in 1..n {
        let d = [0, 1].map(|a| (reference[a][i] - reference[a][i - 1]).abs());
        if d[0] > threshold || d[1] > threshold {
            let axis = if d[0] >= d[1] { 0 } else { 1 };
            match starts.last_mut() {
                Some(last) if i - last.0 <= 1 => *last = (i, axis),
                _ => starts.push((i, axis)),
            }
        }
    }
    starts
        .iter()
        .enumerate()
        .map(|(k, &(start, axis))| ReferenceStep {
            start,
            end: starts.get(k + 1).map_or(n, |s| s.0),
            axis,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_steps_of_both_axes() {
        let mut rx = vec![0.0; 100];
        let mut ry = vec![0.0; 100];
        rx[20..].iter_mut().for_each(|v| *v = 10.0);
        ry[50..].iter_mut().for_each(|v| *v = -8.0);
        ry[51..].iter_mut().for_each(|v| *v = -16.0); // spread over two samples
        let s = reference_steps(&[rx, ry], 3.0);
        assert_eq!(
            s,
            vec![
                ReferenceStep {
                    start: 20,
                    end: 51,
                    axis: 0
                },
                ReferenceStep {
                    start: 51,
                    end: 100,
                    axis: 1
                }
            ]
        );
        assert!(reference_steps(&[vec![1.0; 10], vec![1.0; 10]], 3.0).is_empty());
    }
}
