//! The scenes that ship with pulsetrack, embedded so they load with no files on disk.

/// `(file name, RON text)` of every shipped scene.
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "seed-s-curve.ron",
        include_str!("../../../config/scenes/seed-s-curve.ron"),
    ),
    (
        "seed-arc-80.ron",
        include_str!("../../../config/scenes/seed-arc-80.ron"),
    ),
    (
        "seed-arc-145.ron",
        include_str!("../../../config/scenes/seed-arc-145.ron"),
    ),
    (
        "seed-arc-220.ron",
        include_str!("../../../config/scenes/seed-arc-220.ron"),
    ),
    (
        "seed-radial-wrist.ron",
        include_str!("../../../config/scenes/seed-radial-wrist.ron"),
    ),
    (
        "pivot-off-arc-145.ron",
        include_str!("../../../config/scenes/pivot-off-arc-145.ron"),
    ),
    (
        "pivot-off-arc-145-unweighted.ron",
        include_str!("../../../config/scenes/pivot-off-arc-145-unweighted.ron"),
    ),
    (
        "robust-heart-rate.ron",
        include_str!("../../../config/scenes/robust-heart-rate.ron"),
    ),
    (
        "robust-irregular-beats.ron",
        include_str!("../../../config/scenes/robust-irregular-beats.ron"),
    ),
    (
        "robust-lumps.ron",
        include_str!("../../../config/scenes/robust-lumps.ron"),
    ),
    (
        "robust-noise-doubled.ron",
        include_str!("../../../config/scenes/robust-noise-doubled.ron"),
    ),
    (
        "robust-occlusion.ron",
        include_str!("../../../config/scenes/robust-occlusion.ron"),
    ),
    (
        "sensor-errors-arc-145.ron",
        include_str!("../../../config/scenes/sensor-errors-arc-145.ron"),
    ),
    (
        "tissue-misplaced-arc-145.ron",
        include_str!("../../../config/scenes/tissue-misplaced-arc-145.ron"),
    ),
    (
        "tissue-misplaced-arc-145-unweighted.ron",
        include_str!("../../../config/scenes/tissue-misplaced-arc-145-unweighted.ron"),
    ),
    (
        "tight-arc-20.ron",
        include_str!("../../../config/scenes/tight-arc-20.ron"),
    ),
    (
        "tight-arc-30.ron",
        include_str!("../../../config/scenes/tight-arc-30.ron"),
    ),
    (
        "tight-arc-40.ron",
        include_str!("../../../config/scenes/tight-arc-40.ron"),
    ),
    (
        "tight-arc-50.ron",
        include_str!("../../../config/scenes/tight-arc-50.ron"),
    ),
    (
        "tight-arc-60.ron",
        include_str!("../../../config/scenes/tight-arc-60.ron"),
    ),
    (
        "weak-pulse-12kpa.ron",
        include_str!("../../../config/scenes/weak-pulse-12kpa.ron"),
    ),
    (
        "weak-pulse-25kpa.ron",
        include_str!("../../../config/scenes/weak-pulse-25kpa.ron"),
    ),
    (
        "weak-pulse-3kpa.ron",
        include_str!("../../../config/scenes/weak-pulse-3kpa.ron"),
    ),
    (
        "weak-pulse-50kpa.ron",
        include_str!("../../../config/scenes/weak-pulse-50kpa.ron"),
    ),
    (
        "weak-pulse-6kpa.ron",
        include_str!("../../../config/scenes/weak-pulse-6kpa.ron"),
    ),
];

const NAMES: &[&str] = &[
    "seed-s-curve.ron",
    "seed-arc-80.ron",
    "seed-arc-145.ron",
    "seed-arc-220.ron",
    "seed-radial-wrist.ron",
    "pivot-off-arc-145.ron",
    "pivot-off-arc-145-unweighted.ron",
    "robust-heart-rate.ron",
    "robust-irregular-beats.ron",
    "robust-lumps.ron",
    "robust-noise-doubled.ron",
    "robust-occlusion.ron",
    "sensor-errors-arc-145.ron",
    "tissue-misplaced-arc-145.ron",
    "tissue-misplaced-arc-145-unweighted.ron",
    "tight-arc-20.ron",
    "tight-arc-30.ron",
    "tight-arc-40.ron",
    "tight-arc-50.ron",
    "tight-arc-60.ron",
    "weak-pulse-12kpa.ron",
    "weak-pulse-25kpa.ron",
    "weak-pulse-3kpa.ron",
    "weak-pulse-50kpa.ron",
    "weak-pulse-6kpa.ron",
];

/// The file names of the shipped scenes.
pub fn shipped_names() -> &'static [&'static str] {
    NAMES
}

/// A shipped scene's name and text, by file name with or without `.ron`.
pub fn shipped_source(name: &str) -> Option<(&'static str, &'static str)> {
    let wanted = name.strip_suffix(".ron").unwrap_or(name);
    SHIPPED
        .iter()
        .find(|(n, _)| n.strip_suffix(".ron") == Some(wanted))
        .copied()
}
