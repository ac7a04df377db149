//! The control loop's joint-space mode for the stop sweep, on the test double of the ports
//! (three joint inertias without stops, with the gravity the PD compensates): the sweep
//! powers the arm without a Cartesian move, takes the swept joint past its software limit by
//! the overtravel without a fault (the limit check widened for it only), refuses other
//! motion meanwhile, comes back where it started and powers off; `EndSweep` goes straight
//! back; `Disable` powers off at once.

mod plant;

use control::calibration::{JointSettings, Side, StopTargets};
use control::frames::SurfacePoint;
use control::kinematics::JointLimits;
use plant::{ControlCommand, ControlEvent, LoopMode, rig};

fn sweep(seq: u64, joints: &[usize]) -> ControlCommand {
    ControlCommand::SweepStops {
        seq,
        targets: StopTargets::joints(joints).expect("joints"),
        settings: JointSettings::default(),
    }
}

/// Run until the sweep ends; the stops reported, whether it ended early, the faults, and
/// the lowest and highest angle each joint reached.
struct Ended {
    found: Vec<control::calibration::StopFound>,
    aborted: Option<bool>,
    faults: usize,
    lowest: [f64; 3],
    highest: [f64; 3],
}

fn run_to_end(r: &mut plant::Rig, max_cycles: usize, abort_after: Option<usize>) -> Ended {
    let mut e = Ended {
        found: Vec::new(),
        aborted: None,
        faults: 0,
        lowest: [f64::INFINITY; 3],
        highest: [f64::NEG_INFINITY; 3],
    };
    for k in 0..max_cycles {
        if abort_after == Some(k) {
            r.commands
                .try_send(ControlCommand::EndSweep { seq: 999 })
                .expect("queue");
        }
        r.run(1);
        let q = r.status().position_rad;
        for (j, v) in q.iter().enumerate() {
            e.lowest[j] = e.lowest[j].min(*v);
            e.highest[j] = e.highest[j].max(*v);
        }
        while let Ok(ev) = r.events.try_recv() {
            match ev {
                ControlEvent::StopFound { found, .. } => e.found.push(found),
                ControlEvent::SweepEnded { aborted, .. } => e.aborted = Some(aborted),
                ControlEvent::Faulted(_) => e.faults += 1,
                _ => {}
            }
        }
        if e.aborted.is_some() || e.faults > 0 {
            break;
        }
    }
    e
}

#[test]
fn the_sweep_passes_the_swept_limit_only_comes_home_and_powers_off() {
    let mut r = rig();
    r.run(50);
    let start = r.status().position_rad;
    let e = r.send(|seq| sweep(seq, &[0]));
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    assert_eq!(r.status().mode, LoopMode::Enabled);
    let refused = r.send(|seq| ControlCommand::MoveTo {
        seq,
        target: SurfacePoint::new(0.0, 0.0),
        speed_m_s: 0.01,
    });
    assert!(
        matches!(&refused, ControlEvent::Refused { why, .. } if why.describe().contains("sweep")),
        "{refused:?}"
    );
    let again = r.send(|seq| sweep(seq, &[1]));
    assert!(matches!(again, ControlEvent::Refused { .. }), "{again:?}");

    let ended = run_to_end(&mut r, 80_000, None);
    assert_eq!(ended.faults, 0, "faulted");
    assert_eq!(ended.aborted, Some(false), "did not end");
    let l = JointLimits::default();
    let s = JointSettings::default();
    // No stops on this plant: each side reaches the end of the overtravel freely.
    assert_eq!(ended.found.len(), 2, "{:?}", ended.found);
    for f in &ended.found {
        assert!(!f.stalled, "{f:?}");
        assert!(f.margin_rad(&l) >= s.overtravel_rad - 1e-9, "{f:?}");
    }
    assert_eq!(ended.found[0].side, Side::Lower);
    assert!(ended.lowest[0] < l.min_rad[0] - 0.09, "{:?}", ended.lowest);
    assert!(
        ended.highest[0] > l.max_rad[0] + 0.09,
        "{:?}",
        ended.highest
    );
    // The held joints stayed put.
    for j in 1..3 {
        assert!(
            (ended.highest[j] - ended.lowest[j]).abs() < 0.02,
            "joint {j} moved: {} .. {}",
            ended.lowest[j],
            ended.highest[j]
        );
    }
    let st = r.status();
    assert_eq!(st.mode, LoopMode::Disabled);
    for (q, q0) in st.position_rad.iter().zip(start) {
        assert!((q - q0).abs() < 0.011, "{st:?}");
    }
    // The limits are the configured ones again: enable still works where it started.
    assert!(matches!(
        r.send(|seq| ControlCommand::Enable { seq }),
        ControlEvent::Done { .. }
    ));
}

#[test]
fn ending_the_sweep_goes_straight_home_and_disable_powers_off_at_once() {
    let mut r = rig();
    r.run(50);
    let start = r.status().position_rad;
    r.send(|seq| sweep(seq, &[0]));
    let ended = run_to_end(&mut r, 40_000, Some(3000));
    assert_eq!(ended.aborted, Some(true));
    assert!(ended.found.is_empty(), "{:?}", ended.found);
    let st = r.status();
    assert_eq!(st.mode, LoopMode::Disabled);
    assert!((st.position_rad[0] - start[0]).abs() < 0.011, "{st:?}");

    r.send(|seq| sweep(seq, &[0]));
    r.run(2000);
    let e = r.send(|seq| ControlCommand::Disable { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    assert_eq!(r.status().mode, LoopMode::Disabled);
    let end = r.send(|seq| ControlCommand::EndSweep { seq });
    assert!(
        matches!(end, ControlEvent::Refused { .. }),
        "no sweep left: {end:?}"
    );
}
