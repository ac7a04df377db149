//! The CAN driver against recorded bus traffic: candump logs (drivers/testdata, written by
//! make_phantom_logs.py) replayed through socketcan's own log parser.

use pulsetrack_drivers as drivers;

use std::path::PathBuf;
use std::sync::Arc;

use config::schema::CanJoints;
use control::ports::Manipulator;
use control::types::JointTorques;
use drivers::ManualClock;
use drivers::can::protocol::{ControlCommand, Message};
use drivers::can::replay::CandumpReplay;
use drivers::can::scaling::JointScaling;
use drivers::can::{CanError, DriveState, Fault, PhantomCan};

const STEP_S: f64 = 0.00025;

fn log(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("testdata")
        .join(name)
}

struct Replay {
    clock: ManualClock,
    arm: PhantomCan<CandumpReplay>,
}

impl Replay {
    fn new(name: &str) -> Self {
        let clock = ManualClock::new(0.0);
        let replay = CandumpReplay::from_file(&log(name), Arc::new(clock.clone())).expect("log");
        let arm = PhantomCan::new(replay, &CanJoints::default(), Arc::new(clock.clone()));
        Self { clock, arm }
    }

    fn now(&self) -> f64 {
        drivers::Clock::now_s(&self.clock)
    }

    /// Run the 1 kHz-style loop until `until_s`: read, then command a small torque.
    /// `at` is called once per step before reading.
    fn run(&mut self, until_s: f64, mut at: impl FnMut(f64, &mut PhantomCan<CandumpReplay>)) {
        while self.now() < until_s - 1e-12 {
            self.clock.advance(STEP_S);
            let t = self.now();
            at(t, &mut self.arm);
            let _ = self.arm.read_joints();
            let _ = self.arm.write_torques(&JointTorques {
                torque_nm: [0.05; 3],
            });
        }
    }

    fn sent(&self) -> Vec<Message> {
        self.arm
            .adapter()
            .sent()
            .iter()
            .filter_map(|f| Message::decode(f).ok().flatten())
            .filter(|m| !matches!(m, Message::Heartbeat { .. }))
            .collect()
    }
}

fn enable_at(t_enable: f64) -> impl FnMut(f64, &mut PhantomCan<CandumpReplay>) {
    let mut done = false;
    move |t, arm| {
        if !done && t >= t_enable {
            done = true;
            arm.enable().expect("enable");
        }
    }
}

fn is_torque(m: &Message) -> bool {
    matches!(m, Message::Torque { .. })
}

#[test]
fn enable_and_follow_the_encoders() {
    let mut r = Replay::new("phantom-enable.log");
    assert!(r.arm.adapter().bad_lines().is_empty());
    r.run(0.0095, enable_at(0.005));
    assert!(matches!(r.arm.state(), DriveState::Enabling { .. }));
    assert!(
        !r.sent().iter().any(is_torque),
        "no torque before every amplifier is enabled"
    );
    r.run(0.0395, |_, _| {});
    assert_eq!(*r.arm.state(), DriveState::Enabled);

    let js = r.arm.read_joints().expect("state");
    let s = JointScaling::for_joints(&CanJoints::default());
    // The log's last feedback: joint 0 at 2 * 39 counts, joint 1 at -39, joint 2 at 500.
    assert!((js.position_rad[0] - 78.0 * s[0].rad_per_count).abs() < 1e-12);
    assert!((js.position_rad[1] + 39.0 * s[1].rad_per_count).abs() < 1e-12);
    assert!((js.position_rad[2] - 500.0 * s[2].rad_per_count).abs() < 1e-12);
    // Velocities from the amplifiers' own 1 ms spacing.
    assert!((js.velocity_rad_s[0] - 2.0 * s[0].rad_per_count / 0.001).abs() < 1e-6);
    assert!((js.velocity_rad_s[1] + s[1].rad_per_count / 0.001).abs() < 1e-6);
    assert!(js.velocity_rad_s[2].abs() < 1e-12);
    let st = r.arm.stats();
    assert_eq!((st.feedback, st.feedback_gaps, st.malformed), (120, 0, 0));

    let sent = r.sent();
    let enable = sent
        .iter()
        .position(|m| {
            *m == Message::Control {
                command: ControlCommand::Enable,
                node: 0,
            }
        })
        .expect("enable sent");
    let first_torque = sent.iter().position(is_torque).expect("torques sent");
    assert!(first_torque > enable);
    // 0.05 N·m at joint 0 through 13.3 is 3.76 mN·m: 376 counts.
    assert!(sent.contains(&Message::Torque {
        node: 1,
        torque: 376,
        seq: 1
    }));
}

#[test]
fn bus_off_in_the_log_faults_and_stops_commands() {
    let mut r = Replay::new("phantom-busoff.log");
    r.run(0.0300, enable_at(0.005));
    assert_eq!(*r.arm.state(), DriveState::Enabled);
    r.run(0.0330, |_, _| {});
    match r.arm.state() {
        DriveState::Fault(Fault::BusOff { adapter }) => assert_eq!(adapter, "candump replay"),
        other => panic!("{other:?}"),
    }
    // Torques went out until the bus-off at 30.5 ms; after the broadcast disable, none.
    let sent = r.sent();
    let disable = Message::Control {
        command: ControlCommand::Disable,
        node: 0,
    };
    let at = sent
        .iter()
        .position(|m| *m == disable)
        .expect("disable sent");
    assert!(sent[..at].iter().any(is_torque));
    assert!(!sent[at..].iter().any(is_torque), "{:?}", &sent[at..]);
    // Before the controller restarts, enabling is refused; after, it is allowed.
    match r.arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("bus-off"), "{why}"),
        other => panic!("{other:?}"),
    }
    r.run(0.0370, |_, _| {});
    r.arm.enable().expect("bus restarted and feedback fresh");
}

#[test]
fn error_passive_in_the_log_faults_after_a_warning() {
    let mut r = Replay::new("phantom-error-passive.log");
    r.run(0.0240, enable_at(0.005));
    assert_eq!(
        *r.arm.state(),
        DriveState::Enabled,
        "a warning alone does not stop the arm"
    );
    assert_eq!(r.arm.stats().bus_warnings, 1);
    r.run(0.0290, |_, _| {});
    assert!(matches!(
        r.arm.state(),
        DriveState::Fault(Fault::ErrorPassive { .. })
    ));
}

#[test]
fn estop_in_the_log_faults_and_blocks_enable_until_released() {
    let mut r = Replay::new("phantom-estop.log");
    r.run(0.0260, enable_at(0.005));
    match r.arm.state() {
        DriveState::Fault(Fault::Emergency {
            joint: 0,
            code: 0x5441,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    let before = r.sent().len();
    r.run(0.0300, |_, _| {});
    match r.arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("e-stop"), "{why}"),
        other => panic!("{other:?}"),
    }
    r.run(0.0340, |_, _| {});
    assert!(!r.sent()[before..].iter().any(is_torque));
    r.arm.enable().expect("released");
    assert!(matches!(r.arm.state(), DriveState::Enabling { .. }));
}

#[test]
fn a_silent_amplifier_in_the_log_trips_the_watchdog() {
    let mut r = Replay::new("phantom-silent.log");
    r.run(0.0240, enable_at(0.005));
    assert_eq!(*r.arm.state(), DriveState::Enabled);
    r.run(0.0290, |_, _| {});
    match r.arm.state() {
        DriveState::Fault(Fault::FeedbackTimeout {
            joint: 1,
            age_s,
            limit_s,
        }) => {
            assert!(*age_s > *limit_s)
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn garbage_in_the_log_is_counted_and_ignored() {
    let mut r = Replay::new("phantom-garbage.log");
    assert_eq!(
        r.arm.adapter().bad_lines().len(),
        4,
        "{:?}",
        r.arm.adapter().bad_lines()
    );
    r.run(0.0245, enable_at(0.005));
    assert_eq!(*r.arm.state(), DriveState::Enabled);
    let st = r.arm.stats();
    assert_eq!(st.malformed, 3);
    assert_eq!(st.foreign, 5);
    assert_eq!(st.feedback, 75);
}
