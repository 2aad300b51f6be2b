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
