//! Operating states and which verbs each accepts. Pure: the table is tested on its own.
//!
//! ```text
//! disabled --enable--> holding --move/jog/home--> moving --settled--> holding
//!                      holding --mark--> seeding --located/missed--> holding
//!                      holding (2 seeds) --track--> tracking <--pause/resume--> paused
//!                      tracking --finished/stop--> done --move/mark/...--> (as holding)
//!                      holding (no trial) --search--> searching --found/not found/stop--> holding
//!                      holding (no trial) --calibrate tissue--> calibrating --fit/stop--> holding
//! any --fault/estop--> fault --reset--> disabled        enabled states --disable--> disabled
//! ```

use serde::Serialize;

use crate::console::protocol::Verb;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OpState {
    /// Amplifiers off.
    Disabled,
    /// Powered and holding still.
    Holding,
    /// A manual move (move, jog, home) is under way.
    Moving,
    /// Acquiring at a manual placement (a mark).
    Seeding,
    /// Finding the artery in a region on its own (a search).
    Searching,
    /// A calibration procedure moves the arm (the tissue frame's touches).
    Calibrating,
    /// Following the artery.
    Tracking,
    /// Tracking suspended, holding still.
    Paused,
    /// A trial ended; powered and holding still.
    Done,
    /// A fault is latched; power is off until reset.
    Fault,
}

impl OpState {
    /// Every state, in declaration order: `ALL[s as usize] == s` (the console's greeting
    /// reads the state from its code).
    pub const ALL: [OpState; 10] = [
        OpState::Disabled,
        OpState::Holding,
        OpState::Moving,
        OpState::Seeding,
        OpState::Searching,
        OpState::Calibrating,
        OpState::Tracking,
        OpState::Paused,
        OpState::Done,
        OpState::Fault,
    ];

    pub fn as_str(&self) -> &'static str {
        match self {
            OpState::Disabled => "disabled",
            OpState::Holding => "holding",
            OpState::Moving => "moving",
            OpState::Seeding => "seeding",
            OpState::Searching => "searching",
            OpState::Calibrating => "calibrating",
            OpState::Tracking => "tracking",
            OpState::Paused => "paused",
            OpState::Done => "done",
            OpState::Fault => "fault",
        }
    }

    pub fn powered(&self) -> bool {
        !matches!(self, OpState::Disabled | OpState::Fault)
    }
}

/// What the table needs to know beyond the state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Context {
    /// Seed points located in the current trial.
    pub seeds: usize,
    /// Seed points a track needs.
    pub seeds_needed: usize,
    /// `console.debug_hooks`.
    pub debug_hooks: bool,
    /// A trial is open (a seed is marked, or a track runs).
    pub trial_open: bool,
    /// A calibration recording is under way.
    pub calibrating: bool,
}

/// Accept `verb` in `state`, or say why not.
pub fn admit(state: OpState, verb: &Verb, ctx: &Context) -> Result<(), String> {
    use OpState as S;
    let s = state.as_str();
    let refuse = |why: &str| Err(format!("cannot {} while {s}: {why}", verb.name()));
    let moves_or_marks = matches!(
        verb,
        Verb::Home
            | Verb::Jog { .. }
            | Verb::Move { .. }
            | Verb::Mark
            | Verb::Track { .. }
            | Verb::Search { .. }
    );
    if ctx.calibrating && moves_or_marks {
        return refuse("a calibration recording is under way; wait for it or stop it");
    }
    if state == S::Calibrating && !matches!(verb, Verb::Stop | Verb::Disable) {
        match verb {
            Verb::Status | Verb::Subscribe { .. } | Verb::Unsubscribe | Verb::Estop => {}
            Verb::Debug(_) if ctx.debug_hooks => {}
            _ => return refuse("a calibration is moving the arm; stop it first"),
        }
    }
    match verb {
        Verb::Calibrate(step) if step.moves_arm() => match state {
            S::Holding | S::Done if ctx.trial_open => {
                refuse("a trial is open (a seed is marked); stop it first")
            }
            S::Holding | S::Done if ctx.calibrating => {
                refuse("a calibration recording is under way; wait for it or stop it")
            }
            S::Holding | S::Done => Ok(()),
            S::Disabled => refuse("enable first: the procedure moves the arm"),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("wait for the move to settle"),
            S::Seeding | S::Tracking | S::Paused => refuse("a trial is running; stop it first"),
            S::Searching => refuse("a search is running; stop it first"),
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Calibrate(_) => match state {
            S::Disabled | S::Holding | S::Done if ctx.trial_open => {
                refuse("a trial is open (a seed is marked); stop it first")
            }
            S::Disabled | S::Holding | S::Done => Ok(()),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("wait for the move to settle"),
            S::Seeding | S::Tracking | S::Paused => refuse("a trial is running; stop it first"),
            S::Searching => refuse("a search is running; stop it first"),
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Search { .. } => match state {
            S::Holding | S::Done if ctx.trial_open => {
                refuse("a trial is open (a seed is marked); stop it first")
            }
            S::Holding | S::Done => Ok(()),
            S::Disabled => refuse("enable first"),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("wait for the move to settle"),
            S::Seeding | S::Tracking | S::Paused => refuse("a trial is running; stop it first"),
            S::Searching => refuse("already searching"),
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Status | Verb::Subscribe { .. } | Verb::Unsubscribe | Verb::Estop => Ok(()),
        Verb::Debug(_) => {
            if ctx.debug_hooks {
                Ok(())
            } else {
                Err("debug hooks are off (console.debug_hooks in the config)".into())
            }
        }
        Verb::Enable => match state {
            S::Disabled => Ok(()),
            S::Fault => refuse("a fault is latched; reset first"),
            _ => refuse("already enabled"),
        },
        Verb::Disable => match state {
            S::Disabled => refuse("already disabled"),
            S::Fault => refuse("power is already off; reset clears the fault"),
            _ => Ok(()),
        },
        Verb::Home | Verb::Jog { .. } | Verb::Move { .. } => match state {
            S::Holding | S::Done => Ok(()),
            S::Disabled => refuse("enable first"),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("a move is under way; stop it first"),
            S::Seeding => refuse("a mark is acquiring; wait for it or stop"),
            S::Tracking | S::Paused => refuse("a track is running; stop it first"),
            S::Searching => refuse("a search is running; stop it first"),
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Mark => match state {
            S::Holding | S::Done => {
                if state == S::Holding && ctx.seeds >= ctx.seeds_needed && ctx.seeds_needed > 0 {
                    refuse("both seed points are marked; track, or stop to start over")
                } else {
                    Ok(())
                }
            }
            S::Disabled => refuse("enable first"),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("wait for the move to settle"),
            S::Seeding => refuse("a mark is already acquiring"),
            S::Tracking | S::Paused => refuse("a track is running"),
            S::Searching => refuse("a search is running; stop it first"),
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Track { .. } => match state {
            S::Holding => {
                if ctx.seeds >= ctx.seeds_needed {
                    Ok(())
                } else {
                    refuse(&format!(
                        "tracking needs {} marked seed points; have {}",
                        ctx.seeds_needed, ctx.seeds
                    ))
                }
            }
            S::Done => refuse("the trial has ended; mark two new seed points"),
            S::Disabled => refuse("enable first"),
            S::Fault => refuse("a fault is latched; reset first"),
            S::Moving => refuse("wait for the move to settle"),
            S::Seeding => refuse("wait for the mark to finish"),
            S::Tracking => refuse("already tracking"),
            S::Paused => refuse("paused; resume instead"),
            S::Searching => {
                refuse("a search is running; it seeds no tracker itself (docs/search.md)")
            }
            S::Calibrating => refuse("a calibration is moving the arm; stop it first"),
        },
        Verb::Pause => match state {
            S::Tracking => Ok(()),
            S::Paused => refuse("already paused"),
            _ => refuse("nothing is tracking"),
        },
        Verb::Resume => match state {
            S::Paused => Ok(()),
            _ => refuse("nothing is paused"),
        },
        Verb::Stop => match state {
            _ if ctx.calibrating && state != S::Fault => Ok(()),
            S::Moving | S::Seeding | S::Searching | S::Calibrating | S::Tracking | S::Paused => {
                Ok(())
            }
            S::Holding | S::Done => refuse("nothing is moving"),
            S::Disabled => refuse("power is off"),
            S::Fault => refuse("a fault is latched; power is already off"),
        },
        Verb::Reset => match state {
            S::Fault => Ok(()),
            _ => refuse("no fault is latched"),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [OpState; 10] = OpState::ALL;

    #[test]
    fn each_state_is_read_back_from_its_code() {
        for s in ALL {
            assert_eq!(crate::supervisor::state_from_code(s as u8), s, "{s:?}");
        }
        assert_eq!(crate::supervisor::state_from_code(200), OpState::Disabled);
    }

    fn ctx(seeds: usize) -> Context {
        Context {
            seeds,
            seeds_needed: 2,
            ..Default::default()
        }
    }

    fn accepted(verb: &Verb, seeds: usize) -> Vec<OpState> {
        ALL.iter()
            .copied()
            .filter(|s| admit(*s, verb, &ctx(seeds)).is_ok())
            .collect()
    }

    #[test]
    fn the_table() {
        use OpState::*;
        assert_eq!(accepted(&Verb::Enable, 0), vec![Disabled]);
        assert_eq!(accepted(&Verb::Reset, 0), vec![Fault]);
        assert_eq!(accepted(&Verb::Estop, 0), ALL.to_vec());
        assert_eq!(accepted(&Verb::Status, 0), ALL.to_vec());
        assert_eq!(
            accepted(
                &Verb::Move {
                    x_m: 0.0,
                    z_m: 0.0,
                    speed_m_s: None
                },
                0
            ),
            vec![Holding, Done]
        );
        assert_eq!(accepted(&Verb::Mark, 1), vec![Holding, Done]);
        assert_eq!(accepted(&Verb::Mark, 2), vec![Done]);
        assert_eq!(
            accepted(
                &Verb::Track {
                    length_m: None,
                    label: None
                },
                1
            ),
            Vec::<OpState>::new()
        );
        assert_eq!(
            accepted(
                &Verb::Track {
                    length_m: None,
                    label: None
                },
                2
            ),
            vec![Holding]
        );
        assert_eq!(accepted(&Verb::Pause, 2), vec![Tracking]);
        assert_eq!(accepted(&Verb::Resume, 2), vec![Paused]);
        assert_eq!(
            accepted(&Verb::Stop, 2),
            vec![Moving, Seeding, Searching, Calibrating, Tracking, Paused]
        );
        assert_eq!(
            accepted(&Verb::Disable, 0),
            vec![
                Holding,
                Moving,
                Seeding,
                Searching,
                Calibrating,
                Tracking,
                Paused,
                Done
            ]
        );
        let search = Verb::Search {
            region: control::search::Region::square(
                control::frames::SurfacePoint::new(0.0, 0.0),
                0.04,
            )
            .expect("region"),
            method: control::search::SearchMethod::Search,
            heading_rad: None,
        };
        assert_eq!(accepted(&search, 0), vec![Holding, Done]);
        // Not over an open trial, nor during a calibration recording.
        let open = Context {
            trial_open: true,
            ..ctx(1)
        };
        assert!(ALL.iter().all(|s| admit(*s, &search, &open).is_err()));
        let calibrating = Context {
            calibrating: true,
            ..ctx(0)
        };
        assert!(
            ALL.iter()
                .all(|s| admit(*s, &search, &calibrating).is_err())
        );
        // Nothing moves the arm or marks while a search runs.
        for verb in [
            Verb::Mark,
            Verb::Home,
            Verb::Track {
                length_m: None,
                label: None,
            },
            search.clone(),
        ] {
            assert!(admit(Searching, &verb, &ctx(0)).is_err(), "{verb:?}");
        }
    }

    #[test]
    fn a_tissue_calibration_moves_the_arm_alone_and_only_from_rest_outside_a_trial() {
        use crate::console::protocol::CalibrateStep;
        use OpState::*;
        let touch = Verb::Calibrate(CalibrateStep::TissueTouch {
            points: vec![control::frames::SurfacePoint::new(0.0, 0.0); 3],
            course: None,
            course_lateral_m: 0.0,
        });
        assert_eq!(accepted(&touch, 0), vec![Holding, Done]);
        let open = Context {
            trial_open: true,
            ..ctx(1)
        };
        assert!(ALL.iter().all(|s| admit(*s, &touch, &open).is_err()));
        let recording = Context {
            calibrating: true,
            ..ctx(0)
        };
        assert!(ALL.iter().all(|s| admit(*s, &touch, &recording).is_err()));
        let r = admit(Disabled, &touch, &ctx(0)).expect_err("unpowered");
        assert!(r.contains("enable first"), "{r}");
        // While it runs only stop, disable, estop and the read-only verbs pass.
        for verb in [
            Verb::Mark,
            Verb::Home,
            Verb::Move {
                x_m: 0.0,
                z_m: 0.0,
                speed_m_s: None,
            },
            Verb::Jog {
                dx_m: 0.001,
                dz_m: 0.0,
            },
            Verb::Pause,
            Verb::Resume,
            Verb::Reset,
            Verb::Enable,
            touch.clone(),
        ] {
            let r = admit(Calibrating, &verb, &ctx(0)).expect_err("busy");
            assert!(r.contains("while calibrating"), "{verb:?}: {r}");
        }
        for verb in [Verb::Stop, Verb::Disable, Verb::Estop, Verb::Status] {
            assert!(admit(Calibrating, &verb, &ctx(0)).is_ok(), "{verb:?}");
        }
    }

    #[test]
    fn refusals_say_the_verb_the_state_and_why() {
        let r = admit(
            OpState::Disabled,
            &Verb::Track {
                length_m: None,
                label: None,
            },
            &ctx(0),
        )
        .expect_err("refused");
        assert_eq!(r, "cannot track while disabled: enable first");
        let r = admit(
            OpState::Holding,
            &Verb::Track {
                length_m: None,
                label: None,
            },
            &ctx(1),
        )
        .expect_err("refused");
        assert!(r.contains("needs 2 marked seed points; have 1"), "{r}");
        let r = admit(
            OpState::Holding,
            &Verb::Debug(crate::console::protocol::DebugAction::SilenceTactile { duration_s: 1.0 }),
            &ctx(0),
        )
        .expect_err("refused");
        assert!(r.contains("debug_hooks"), "{r}");
    }

    #[test]
    fn a_calibration_records_only_at_rest_outside_a_trial_and_holds_the_arm_still() {
        use OpState::*;
        let tare = Verb::Calibrate(crate::console::protocol::CalibrateStep::TactileTare {
            duration_s: None,
        });
        assert_eq!(accepted(&tare, 0), vec![Disabled, Holding, Done]);
        let open = Context {
            trial_open: true,
            ..ctx(1)
        };
        let r = admit(Holding, &tare, &open).expect_err("a seed is marked");
        assert!(r.contains("trial is open"), "{r}");
        // While it records, nothing moves the arm or marks, and stop ends it.
        let recording = Context {
            calibrating: true,
            ..ctx(0)
        };
        for verb in [
            Verb::Home,
            Verb::Mark,
            Verb::Move {
                x_m: 0.0,
                z_m: 0.0,
                speed_m_s: None,
            },
        ] {
            let r = admit(Holding, &verb, &recording).expect_err("recording");
            assert!(r.contains("calibration recording"), "{r}");
        }
        for s in [Disabled, Holding, Done] {
            assert!(admit(s, &Verb::Stop, &recording).is_ok(), "{s:?}");
            assert!(admit(s, &Verb::Estop, &recording).is_ok(), "{s:?}");
        }
    }
}
