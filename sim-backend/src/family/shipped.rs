//! The families that ship with pulsetrack, embedded so they load with no files on disk.

/// `(file name, RON text)` of every shipped family.
pub const SHIPPED_FAMILIES: &[(&str, &str)] = &[
    (
        "smooth-random.ron",
        include_str!("../../../config/families/smooth-random.ron"),
    ),
    (
        "sinusoids.ron",
        include_str!("../../../config/families/sinusoids.ron"),
    ),
    (
        "spirals.ron",
        include_str!("../../../config/families/spirals.ron"),
    ),
    (
        "bends.ron",
        include_str!("../../../config/families/bends.ron"),
    ),
    (
        "fast-irregular-heart.ron",
        include_str!("../../../config/families/fast-irregular-heart.ron"),
    ),
    (
        "heavy-instrument.ron",
        include_str!("../../../config/families/heavy-instrument.ron"),
    ),
    (
        "breathing.ron",
        include_str!("../../../config/families/breathing.ron"),
    ),
    (
        "seed-bench-mixed.ron",
        include_str!("../../../config/families/seed-bench-mixed.ron"),
    ),
];

/// The file names of the shipped families.
pub fn shipped_family_names() -> Vec<&'static str> {
    SHIPPED_FAMILIES.iter().map(|(n, _)| *n).collect()
}

/// A shipped family's name and text, by file name with or without `.ron`.
pub fn shipped_family_source(name: &str) -> Option<(&'static str, &'static str)> {
    let wanted = name.strip_suffix(".ron").unwrap_or(name);
    SHIPPED_FAMILIES
        .iter()
        .find(|(n, _)| n.strip_suffix(".ron") == Some(wanted))
        .copied()
}
