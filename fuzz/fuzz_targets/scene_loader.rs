//! The simulator's scene files: arbitrary text through `config::load_str::<Scene>` (what
//! `sim::scene::load` does with a file), then, for an accepted scene, the bench the daemon's
//! rig and the runner build from it, run for a few hundred control periods with the ideal
//! robot and with the dynamic arm (enabled, zero torque). Nothing may panic. A refusal names
//! the origin; an accepted scene validates again, its artery path builds with a finite
//! length and finite points, and every frame and the bench's truth are finite.
//!
//! Bounded work: scenes with the FEM kernel are loaded and validated but not built (the
//! kernel is solved and cached on disk, seconds per scene); the time step is the config's.
#![no_main]

use std::sync::LazyLock;

use config::{Validate, Validator};
use control::types::JointTorques;
use libfuzzer_sys::fuzz_target;
use sim::bench::Bench;
use sim::scene::{ArteryPath, PressureKernel, Scene};

const ORIGIN: &str = "fuzz-scene.ron";
/// Control periods run per arm (0.3 s at the shipped 1 kHz).
const STEPS: usize = 300;

static SIM_CONFIG: LazyLock<config::Config> = LazyLock::new(|| {
    let (name, text) = config::shipped::SIM_CONFIG;
    config::load_str(name, text).expect("the shipped config loads")
});

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let scene = match config::load_str::<Scene>(ORIGIN, text) {
        Err(e) => {
            assert_eq!(e.file, ORIGIN);
            assert!(!e.problems.is_empty());
            for line in e.to_string().lines() {
                assert!(line.starts_with(ORIGIN), "names no file: {line:?}");
            }
            return;
        }
        Ok(s) => s,
    };
    let mut v = Validator::new();
    scene.validate(&mut v);
    let again = v.into_problems();
    assert!(again.is_empty(), "accepted, then: {again:?}");

    let path = ArteryPath::from_spec(&scene.artery.path).expect("a valid scene's path builds");
    let len = path.length_m();
    assert!(len.is_finite() && len > 0.0, "path length {len}");
    for k in 0..=8 {
        let (p, heading) = path.at(len * f64::from(k) / 8.0);
        assert!(
            p.is_finite() && heading.is_finite(),
            "path point {p:?} {heading}"
        );
    }
    let n = path.nearest(scene.placements[0]);
    assert!(
        n.s_m.is_finite() && n.offset_m.is_finite() && n.point.is_finite(),
        "{n:?}"
    );

    if matches!(scene.artery.kernel, PressureKernel::Fem(_)) {
        return;
    }
    for ideal in [true, false] {
        let mut bench = match Bench::new(&scene, &SIM_CONFIG, 7, ideal) {
            Ok(b) => b,
            // The dynamic arm may not reach the scene's start: a refusal, not a bug.
            Err(e) => {
                assert!(!ideal, "the ideal bench refused a valid scene: {e}");
                assert!(!e.to_string().trim().is_empty());
                continue;
            }
        };
        bench.set_enabled(true);
        bench
            .write_torques(&JointTorques::ZERO)
            .expect("zero torque");
        for _ in 0..STEPS {
            if let Some(f) = bench.step() {
                assert!(
                    f.t_s.is_finite() && f.force_n.iter().all(|x| x.is_finite()),
                    "frame {f:?} (ideal {ideal})"
                );
            }
        }
        let t = bench.truth();
        assert!(
            t.sensor.is_finite()
                && t.rigid_sensor.is_finite()
                && t.height_m.is_finite()
                && t.normal_n.is_finite()
                && t.friction_n.iter().all(|x| x.is_finite())
                && t.pulse_pa.is_finite(),
            "truth {t:?} (ideal {ideal})"
        );
        let j = bench.read_joints();
        assert!(
            j.position_rad.iter().all(|x| x.is_finite())
                && j.velocity_rad_s.iter().all(|x| x.is_finite()),
            "joints {j:?}"
        );
    }
});
