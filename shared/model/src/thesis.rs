//! Tables printed in the thesis that tools compare against.

/// Table 4.1 as printed: (α1°, α2°, [K_low,1, K_high,1, K_low,2, K_high,2]) in N·m/rad,
/// the joint stiffness set at the five trial points. The model gives joint 1's K_low about
/// 1 N·m/rad lower everywhere (see the README, "Reproduced values").
pub const TABLE_4_1: [(f64, f64, [f64; 4]); 5] = [
    (0.0, 0.0, [60.8, 110.0, 26.6, 46.8]),
    (-16.0, 20.5, [117.2, 138.1, 44.1, 55.0]),
    (16.5, -26.0, [121.2, 141.1, 56.3, 64.2]),
    (10.0, 6.5, [81.2, 113.8, 28.2, 45.9]),
    (-13.5, -11.5, [99.5, 125.3, 31.8, 47.2]),
];

/// The five trial points of Table 4.1, (α1, α2) in degrees: the dynamic and static trials'
/// poses (§4.2).
pub const TABLE_4_1_POINTS_DEG: [[f64; 2]; 5] = {
    let mut p = [[0.0; 2]; 5];
    let mut i = 0;
    while i < 5 {
        p[i] = [TABLE_4_1[i].0, TABLE_4_1[i].1];
        i += 1;
    }
    p
};

/// The nine poses of the force-step test (§5.2), in the thesis's order, degrees.
pub const STEP_POSES_DEG: [[f64; 2]; 9] = [
    [0.0, 0.0],
    [0.0, 15.0],
    [0.0, -15.0],
    [15.0, 0.0],
    [15.0, 15.0],
    [15.0, -15.0],
    [-15.0, 0.0],
    [-15.0, 15.0],
    [-15.0, -15.0],
];

/// Force-step size and largest reference of the force-step test (§5.2), N.
pub const STEP_N: f64 = 9.1;
/// See [`STEP_N`].
pub const STEP_MAX_N: f64 = 27.3;
