//! The whole simulated bench stepped at the servo rate: the Phantom under torque, the rod
//! through the compliant pivot, the sensor on the tissue, and tactile frames from where the
//! sensor truly is.
//!
//! What the robot believes (encoders through the configured, fixed-pivot model) and where
//! the sensor truly is are kept apart: [`Bench::read_joints`] is all a controller sees;
//! [`Bench::truth`] is the experimenter's view.

use control::frames::{SurfacePoint, TissuePlacement};
use control::kinematics::{ArmModel, PhantomGeometry, phantom};
use control::pd::gravity::{GravityModel, PhantomGravity};
use control::types::{ELEMENTS, JointState, JointTorques, Joints, TactileFrame};
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use rand::rngs::ChaCha8Rng;

use crate::error::SimError;
use crate::physics::contact::{ContactState, TissueContact};
use crate::physics::joints::{Encoders, JointDynamics};
use crate::physics::rod::{GRAVITY_M_S2, Rod};
use crate::physics::tactile::{Attitude, Contact, TactileModel};
use crate::random::{Stream, standard_normal, stream, stream_seed, uniform_open};
use crate::scene::{ArteryPath, PinAxis, PressureKernel, PulseSource, RobotSpec, Scene};

/// Where the sensor truly is and what it presses on, at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimTruth {
    /// Simulated time, s.
    pub t_s: f64,
    /// The true centre of the element line on the tissue plane.
    pub sensor: SurfacePoint,
    /// Height of the element line above the surface (negative: pressed in), m.
    pub height_m: f64,
    /// Where a rigid rod through the configured pivot would put the sensor (what the robot
    /// believes, before encoder quantization).
    pub rigid_sensor: SurfacePoint,
    /// Normal force on the sensor, N.
    pub normal_n: f64,
    /// The tissue's lateral force on the sensor (tissue x, z), N.
    pub friction_n: [f64; 2],
    pub sliding: bool,
    /// Pulsatile lumen pressure, Pa.
    pub pulse_pa: f64,
}

/// How the arm moves: the full plant, or an ideal robot that puts the sensor exactly where
/// it is told (a scene without robot dynamics, for signal-processing studies).
#[derive(Debug)]
enum Arm {
    Dynamic(Box<DynamicArm>),
    Ideal { sensor: SurfacePoint },
}

#[derive(Debug)]
struct DynamicArm {
    geometry: PhantomGeometry,
    pivot: Point3<f64>,
    rod: Rod,
    contact: TissueContact,
    contact_state: ContactState,
    joints: JointDynamics,
    encoders: Encoders,
    gravity: PhantomGravity,
    saturation: [f64; 3],
    enabled: bool,
    /// The operator's hand holds the joints still until the arm is first powered
    /// (`Scene::held_until_enabled`).
    held: bool,
    /// The instrument is out of the incision: no rod load, no tissue contact.
    instrument_out: bool,
    /// What the encoders add to the true angle, rad (`JointErrorsSpec`).
    encoder_zero_error_rad: Joints,
    command: JointTorques,
    /// The latest contact solution, for frames and truth.
    normal_n: f64,
    indentation_m: f64,
    friction_n: [f64; 2],
    sliding: bool,
    sensor: SurfacePoint,
    rigid_sensor: SurfacePoint,
    height_m: f64,
    /// The pin joint, when the scene models it, and the body's radius (the pin is on the
    /// body's axis, this far above the element line).
    pin: Option<PinAxis>,
    body_radius_m: f64,
    attitude: Attitude,
    /// The contact patch's centre when it differs from the element line's.
    patch_centre: Option<SurfacePoint>,
    incision: Option<IncisionHysteresis>,
}

/// The incision's dry-friction element, in parallel with its lateral spring (tissue plane).
#[derive(Debug, Clone, Copy)]
struct IncisionHysteresis {
    stiffness_n_per_m: f64,
    slip_n: f64,
    /// Where the friction element last stuck (the pivot's shift at which it carries nothing).
    anchor_m: [f64; 2],
    /// The force it carries now.
    force_n: [f64; 2],
}

impl IncisionHysteresis {
    /// The pivot moved to `shift`: the element follows elastically until it slips.
    fn update(&mut self, shift: [f64; 2]) {
        let k = self.stiffness_n_per_m;
        let trial = [
            k * (shift[0] - self.anchor_m[0]),
            k * (shift[1] - self.anchor_m[1]),
        ];
        let size = trial[0].hypot(trial[1]);
        if size > self.slip_n && size > 0.0 {
            let scale = self.slip_n / size;
            self.force_n = [trial[0] * scale, trial[1] * scale];
            self.anchor_m = [
                shift[0] - self.force_n[0] / k,
                shift[1] - self.force_n[1] / k,
            ];
        } else {
            self.force_n = trial;
        }
    }
}

/// Where the simulated array is. On a rig the person calibrating the array takes it off the
/// tissue and puts a known load on it; the simulator stands in for that person.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArrayPlace {
    /// On the tissue, in contact: the readings the trackers use.
    OnTissue,
    /// Off the tissue under a uniform load per element, N (0: nothing touching it).
    OnBench { load_per_element_n: f64 },
}

/// The simulated bench.
#[derive(Debug)]
pub struct Bench {
    scene_name: String,
    arm: Arm,
    placement: TissuePlacement,
    base_from_tissue: Rotation3<f64>,
    sensor_offset: Vector3<f64>,
    tactile: TactileModel,
    pulse: PulseSource,
    noise_rng: ChaCha8Rng,
    fault_rng: ChaCha8Rng,
    noise_sd_n: f64,
    dead: [bool; ELEMENTS],
    /// Each element's reading per newton and at no load (the scene's sensor errors).
    gain: [f64; ELEMENTS],
    offset_n: [f64; ELEMENTS],
    /// Where the array is: on the tissue, or on the bench for its calibration.
    array_place: ArrayPlace,
    drop_probability: f64,
    dt_s: f64,
    frame_dt_s: f64,
    t_s: f64,
    steps: u64,
    next_frame_s: f64,
    seq: u64,
    /// Normal force of the ideal robot's contact (the added mass, or 3 N), N.
    ideal_normal_n: f64,
    ideal_indentation_m: f64,
    /// The tissue's breathing motion, when the scene has it.
    breathing: Option<crate::scene::Breathing>,
}

impl Bench {
    /// Build the bench for `scene` on the rig `config` describes. With `ideal` the arm is
    /// the ideal kinematic robot whatever the scene says.
    pub fn new(
        scene: &Scene,
        config: &config::Config,
        seed: u64,
        ideal: bool,
    ) -> Result<Self, SimError> {
        let scene_err = |message: String| SimError::Scene {
            scene: scene.name.clone(),
            message,
        };
        let path =
            ArteryPath::from_spec(&scene.artery.path).map_err(|e| scene_err(e.to_string()))?;
        let mut tactile = TactileModel::new(
            path,
            &scene.artery,
            &scene.sensor,
            &scene.lumps,
            config.sensor.direction,
        );
        if let PressureKernel::Fem(spec) = &scene.artery.kernel {
            let a = &scene.artery;
            let params = spec.params(a.inner_radius_m, a.wall_m, a.depth_m);
            let (kernel, _) = pulsetrack_fem::kernel::load_or_compute(
                &params,
                &pulsetrack_fem::kernel::default_cache_dir(),
            )
            .map_err(|e| scene_err(format!("FEM kernel: {e}")))?;
            tactile = tactile.with_fem_kernel(std::sync::Arc::new(kernel));
        }
        let rate = config.control.rate_hz;
        let frame_rate = config.sensor.sample_rate_hz;
        if !(rate.is_finite() && rate > 0.0 && frame_rate.is_finite() && frame_rate > 0.0) {
            return Err(SimError::Config(format!(
                "control.rate_hz {rate} and sensor.sample_rate_hz {frame_rate} must be positive"
            )));
        }
        // The tissue where it truly lies (the robot believes the config's placement).
        let placement = scene.tissue.true_placement(&config.robot.tissue);
        let base_from_tissue = Rotation3::from_axis_angle(&Vector3::y_axis(), placement.yaw_rad);
        let sensor_offset = Vector3::from(config.robot.sensor_offset_m);
        let mut dead = [false; ELEMENTS];
        let mut drop_probability = 0.0;
        let mut gain = [1.0; ELEMENTS];
        let mut offset_n = [0.0; ELEMENTS];
        if let Some(f) = &scene.faults {
            for &e in &f.dead_elements {
                if e < ELEMENTS {
                    dead[e] = true;
                }
            }
            drop_probability = f.frame_drop_probability;
            // Validated: one value per element, or none.
            if let Ok(g) = <[f64; ELEMENTS]>::try_from(f.element_gains.as_slice()) {
                gain = g;
            }
            if let Ok(o) = <[f64; ELEMENTS]>::try_from(f.element_offsets_n.as_slice()) {
                offset_n = o;
            }
        }
        let tissue = scene.tissue;
        let ideal_normal_n = scene
            .mass
            .map_or(3.0, |m| (m.mass_kg * GRAVITY_M_S2).max(0.1));
        let start = scene.start.unwrap_or(SurfacePoint::new(
            scene.placements[0].x_m - 0.01,
            scene.placements[0].z_m,
        ));
        let arm = if ideal {
            Arm::Ideal { sensor: start }
        } else {
            Arm::Dynamic(Box::new(DynamicArm::new(scene, config, start)?))
        };
        Ok(Self {
            scene_name: scene.name.clone(),
            arm,
            placement,
            base_from_tissue,
            sensor_offset,
            tactile,
            pulse: PulseSource::new(&scene.pulse, stream_seed(seed, Stream::Pulse)),
            noise_rng: stream(seed, Stream::SensorNoise),
            fault_rng: stream(seed, Stream::Faults),
            noise_sd_n: scene.sensor.noise_sd_n,
            dead,
            gain,
            offset_n,
            array_place: ArrayPlace::OnTissue,
            drop_probability,
            dt_s: 1.0 / rate,
            frame_dt_s: 1.0 / frame_rate,
            t_s: 0.0,
            steps: 0,
            next_frame_s: 1.0 / frame_rate,
            seq: 0,
            ideal_normal_n,
            ideal_indentation_m: ideal_normal_n / tissue.contact_stiffness_n_per_m,
            breathing: tissue.breathing,
        })
    }

    pub fn scene_name(&self) -> &str {
        &self.scene_name
    }

    /// True if this bench moves the sensor kinematically (no arm dynamics).
    pub fn is_ideal(&self) -> bool {
        matches!(self.arm, Arm::Ideal { .. })
    }

    pub fn now_s(&self) -> f64 {
        self.t_s
    }

    /// The control period, s.
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    pub fn path(&self) -> &ArteryPath {
        self.tactile.path()
    }

    /// The pulsatile force on each element per pascal of lumen pressure with the artery at
    /// each of `offsets_m` from the element line's centre, at the artery's point nearest
    /// `near`, the sensor level under the ideal arm's contact load (for the detection
    /// bound: `crate::detection_bound`).
    pub fn pulse_across(
        &mut self,
        near: SurfacePoint,
        offsets_m: &[f64],
    ) -> Vec<(f64, [f64; ELEMENTS])> {
        let artery = self.tactile.path().nearest(near).point;
        let contact = Contact::level(self.ideal_normal_n, self.ideal_indentation_m);
        // Through `forces`, so that the coupling's gain is the simulator's own; the
        // reference pressure is well inside the linear range (no element lifts off).
        const REFERENCE_PA: f64 = 100.0;
        offsets_m
            .iter()
            .map(|&x| {
                let centre = SurfacePoint::new(artery.x_m, artery.z_m - x);
                let rest = self.tactile.forces(centre, contact, 0.0);
                let pulsed = self.tactile.forces(centre, contact, REFERENCE_PA);
                (
                    x,
                    std::array::from_fn(|e| (pulsed[e] - rest[e]) / REFERENCE_PA),
                )
            })
            .collect()
    }

    pub fn set_enabled(&mut self, on: bool) {
        if let Arm::Dynamic(a) = &mut self.arm {
            a.enabled = on;
            // Powered, the arm holds itself: the hand lets go for good.
            a.held &= !on;
            if !on {
                a.command = JointTorques::ZERO;
            }
        }
    }

    /// The measured joint state: encoder-quantized angles and a filtered velocity, stamped
    /// with simulated time. The ideal robot has no joints and reports zeros.
    pub fn read_joints(&self) -> JointState {
        match &self.arm {
            Arm::Dynamic(a) => {
                let (mut q, qd) = a.encoders.read(&a.joints.q);
                for (q, e) in q.iter_mut().zip(a.encoder_zero_error_rad) {
                    *q += e;
                }
                JointState {
                    t_s: self.t_s,
                    position_rad: q,
                    velocity_rad_s: qd,
                }
            }
            Arm::Ideal { .. } => JointState {
                t_s: self.t_s,
                position_rad: [0.0; 3],
                velocity_rad_s: [0.0; 3],
            },
        }
    }

    /// Command joint torques for the coming period (ignored while disabled).
    pub fn write_torques(&mut self, torques: &JointTorques) -> Result<(), SimError> {
        if !torques.is_finite() {
            return Err(SimError::NonFinite("joint torques"));
        }
        if let Arm::Dynamic(a) = &mut self.arm
            && a.enabled
        {
            a.command = *torques;
        }
        Ok(())
    }

    /// The joint torques last commanded (zero for the ideal arm or while disabled): what a
    /// driver knows it asked of the motors.
    pub fn commanded_torque_nm(&self) -> control::types::Joints {
        match &self.arm {
            Arm::Dynamic(a) if a.enabled => a.command.torque_nm,
            _ => [0.0; 3],
        }
    }

    /// Put the ideal robot's sensor somewhere (no effect on the dynamic arm).
    pub fn place_ideal(&mut self, sensor: SurfacePoint) {
        if let Arm::Ideal { sensor: s } = &mut self.arm {
            *s = sensor;
        }
    }

    /// Advance one control period; returns the tactile frame sampled in it, if one was due.
    pub fn step(&mut self) -> Option<TactileFrame> {
        let dt = self.dt_s;
        if let Arm::Dynamic(a) = &mut self.arm {
            a.step(
                &self.placement,
                &self.base_from_tissue,
                &self.sensor_offset,
                dt,
            );
        }
        self.steps += 1;
        // Time as a multiple of the period: no drift from repeated addition.
        self.t_s = self.steps as f64 * dt;
        if self.t_s + 1e-9 >= self.next_frame_s {
            self.next_frame_s += self.frame_dt_s;
            return self.sample_frame();
        }
        None
    }

    /// The sensor and its contact in the frame of the tissue as it lies now (moved back by
    /// the breathing displacement, so the artery and the lumps stay where the scene says).
    fn contact_now(&self) -> (SurfacePoint, Contact) {
        let (sensor, mut contact) = self.contact_in_bench();
        let Some(b) = self.breathing else {
            return (sensor, contact);
        };
        contact.patch_centre = contact.patch_centre.map(|c| b.to_rest(c, self.t_s));
        (b.to_rest(sensor, self.t_s), contact)
    }

    fn contact_in_bench(&self) -> (SurfacePoint, Contact) {
        match &self.arm {
            Arm::Dynamic(a) => (
                a.sensor,
                Contact {
                    normal_n: a.normal_n,
                    indentation_m: a.indentation_m,
                    attitude: a.attitude,
                    patch_centre: a.patch_centre,
                },
            ),
            Arm::Ideal { sensor } => (
                *sensor,
                Contact::level(self.ideal_normal_n, self.ideal_indentation_m),
            ),
        }
    }

    fn sample_frame(&mut self) -> Option<TactileFrame> {
        let (sensor, contact) = self.contact_now();
        let pulse = self.pulse.pressure_pa(self.t_s);
        let clean = match self.array_place {
            ArrayPlace::OnTissue => self.tactile.forces(sensor, contact, pulse),
            ArrayPlace::OnBench { load_per_element_n } => [load_per_element_n; ELEMENTS],
        };
        let mut force_n = [0.0; ELEMENTS];
        for (i, f) in force_n.iter_mut().enumerate() {
            let signal = if self.dead[i] { 0.0 } else { clean[i] };
            *f = self.offset_n[i]
                + self.gain[i] * signal
                + self.noise_sd_n * standard_normal(&mut self.noise_rng);
        }
        let seq = self.seq;
        self.seq += 1;
        if self.drop_probability > 0.0 && uniform_open(&mut self.fault_rng) < self.drop_probability
        {
            return None;
        }
        Some(TactileFrame {
            t_s: self.t_s,
            seq,
            force_n,
        })
    }

    /// Put the array on the tissue, or on the bench under a uniform load for its
    /// calibration. The arm's physics goes on either way: only the array's readings change.
    pub fn place_array(&mut self, place: ArrayPlace) {
        self.array_place = place;
    }

    /// Noise-free element forces right now (for plots and tests).
    pub fn clean_forces(&mut self) -> [f64; ELEMENTS] {
        let (sensor, contact) = self.contact_now();
        let pulse = self.pulse.pressure_pa(self.t_s);
        self.tactile.forces(sensor, contact, pulse)
    }

    /// Beats of the pulse begun by `t_s`.
    pub fn beats_started_by(&mut self, t_s: f64) -> u64 {
        self.pulse.beats_started_by(t_s)
    }

    /// The true rod's mechanics (None: an ideal arm).
    pub fn rod_mechanics(&self) -> Option<control::kinematics::RodMechanics> {
        let Arm::Dynamic(a) = &self.arm else {
            return None;
        };
        // A rigid shaft or incision is one too stiff to bend: the same reading, no deflection.
        const RIGID: f64 = 1e12;
        Some(control::kinematics::RodMechanics {
            bending_stiffness_nm2: a.rod.bending_stiffness_nm2.unwrap_or(RIGID),
            pivot_stiffness_n_per_m: a.rod.pivot_stiffness_n_per_m.unwrap_or(RIGID),
            rod_mass_kg: a.rod.rod_mass_kg,
            tip_mass_kg: a.rod.mass_kg,
            tip_mass_height_m: a.rod.mass_height_m,
        })
    }

    pub fn truth(&mut self) -> SimTruth {
        let pulse_pa = self.pulse.pressure_pa(self.t_s);
        match &self.arm {
            Arm::Dynamic(a) => SimTruth {
                t_s: self.t_s,
                sensor: a.sensor,
                height_m: a.height_m,
                rigid_sensor: a.rigid_sensor,
                normal_n: a.normal_n,
                friction_n: a.friction_n,
                sliding: a.sliding,
                pulse_pa,
            },
            Arm::Ideal { sensor } => SimTruth {
                t_s: self.t_s,
                sensor: *sensor,
                height_m: -self.ideal_indentation_m,
                rigid_sensor: *sensor,
                normal_n: self.ideal_normal_n,
                friction_n: [0.0; 2],
                sliding: false,
                pulse_pa,
            },
        }
    }
}

impl DynamicArm {
    fn new(scene: &Scene, config: &config::Config, start: SurfacePoint) -> Result<Self, SimError> {
        let spec: RobotSpec = scene.robot.unwrap_or_default();
        let geometry = spec.phantom.unwrap_or(config.robot.phantom);
        let mut pivot_geometry = config.robot.pivot;
        let mut pivot_stiffness = None;
        if let Some(p) = &scene.pivot {
            for i in 0..3 {
                pivot_geometry.pivot_in_base_m[i] += p.offset_m[i];
            }
            pivot_stiffness = p.lateral_stiffness_n_per_m;
        }
        if let Some(l) = scene.shaft.and_then(|s| s.length_m) {
            pivot_geometry.rod_length_m = l;
        }
        let rod = Rod::new(
            pivot_geometry.rod_length_m,
            scene.shaft.as_ref(),
            pivot_stiffness,
            scene.mass.as_ref(),
        );
        // Start resting on the surface at `start`: the true arm's inverse kinematics (the
        // same formulas as the robot's model, with the true geometry).
        let truth_model = ArmModel::new(
            geometry,
            config.robot.joint_limits,
            pivot_geometry,
            scene.tissue.true_placement(&config.robot.tissue),
            config.robot.sensor_offset_m,
        )?;
        let errors = scene.joints.unwrap_or_default();
        let q0 = if errors.start_at_reset {
            config.calibration.joints.reset_pose_rad
        } else {
            truth_model.joints_for_sensor(&Point3::new(start.x_m, 0.0, start.z_m))?
        };
        let limits = config.robot.joint_limits;
        // Mechanical stops outside the configured software limits (by default a little).
        let b = errors.stop_beyond_limit_rad;
        let stops = [0, 1, 2].map(|i| (limits.min_rad[i] - b[i][0], limits.max_rad[i] + b[i][1]));
        let masses = spec.masses.unwrap_or(config.robot.link_masses);
        let incision = scene.pivot.and_then(|p| {
            Some(IncisionHysteresis {
                stiffness_n_per_m: p.lateral_stiffness_n_per_m?,
                slip_n: p.hysteresis_slip_n?,
                anchor_m: [0.0; 2],
                force_n: [0.0; 2],
            })
        });
        let mut arm = Self {
            geometry,
            pivot: Point3::from(pivot_geometry.pivot_in_base_m),
            rod,
            contact: TissueContact::new(&scene.tissue),
            contact_state: ContactState::default(),
            joints: JointDynamics::new(&spec, q0, stops),
            encoders: Encoders::new(&spec),
            gravity: PhantomGravity::new(&masses),
            saturation: spec.torque_saturation_nm,
            enabled: false,
            held: scene.held_until_enabled || errors.start_at_reset,
            instrument_out: errors.start_at_reset,
            encoder_zero_error_rad: errors.encoder_zero_error_rad,
            command: JointTorques::ZERO,
            normal_n: 0.0,
            indentation_m: 0.0,
            friction_n: [0.0; 2],
            sliding: false,
            sensor: start,
            rigid_sensor: start,
            height_m: 0.0,
            pin: scene.sensor.mount.map(|m| m.pin),
            body_radius_m: scene.sensor.body_diameter_m / 2.0,
            attitude: Attitude::default(),
            patch_centre: None,
            incision,
        };
        arm.encoders.sample(&q0, 1.0);
        Ok(arm)
    }

    fn step(
        &mut self,
        placement: &TissuePlacement,
        base_from_tissue: &Rotation3<f64>,
        sensor_offset: &Vector3<f64>,
        dt: f64,
    ) {
        let q = self.joints.q;
        let (Ok(g), Ok(jac)) = (
            phantom::forward(&self.geometry, &q),
            phantom::jacobian(&self.geometry, &q),
        ) else {
            // Non-finite joint state cannot happen from finite torques; hold still.
            return;
        };
        let mut tau: Joints = [0.0; 3];
        if self.enabled {
            for (i, t) in tau.iter_mut().enumerate() {
                *t = self.command.torque_nm[i].clamp(-self.saturation[i], self.saturation[i]);
            }
        }
        let holding = self.gravity.torque_nm(&q);
        for i in 0..3 {
            tau[i] -= holding[i];
        }
        let mut extra = Matrix3::zeros();
        let rod = (!self.instrument_out)
            .then(|| self.rod.rigid(&g.0, &self.pivot))
            .flatten();
        if let Some(geom) = rod {
            let rigid_tissue = placement.to_tissue(&geom.tip) + sensor_offset;
            let rigid = [rigid_tissue.x, rigid_tissue.z];
            // The rod's lean in the tissue frame (its lower end toward +x by `along`, toward
            // +z by `across`), which the pin joint passes on to the body or not.
            let axis = base_from_tissue.inverse() * geom.axis;
            let along = axis.x.atan2(-axis.y);
            let across = axis.z.atan2(-axis.y);
            let r = self.body_radius_m;
            // A body tilted sideways with the rod carries its line's centre by r sin β.
            let body_shift = match self.pin {
                Some(PinAxis::AlongLine) => [0.0, r * across.sin()],
                _ => [0.0, 0.0],
            };
            let body = [rigid[0] + body_shift[0], rigid[1] + body_shift[1]];
            let compliance = self.rod.compliance_m_per_n(geom.gimbal_to_pivot_m);
            let other_base = self.rod.perpendicular_load(&geom, self.normal_n);
            let other_tissue = base_from_tissue.inverse() * other_base;
            let other = [other_tissue.x, other_tissue.z];
            // The incision's friction element holds the pivot back: an extra tip
            // displacement of −(L/a) f / k, passed as the load the compliance turns into it.
            let lever = self.rod.length_m / geom.gimbal_to_pivot_m.max(1e-3);
            let mut loads = other;
            if let Some(h) = &self.incision
                && compliance > 0.0
            {
                for (load, force) in loads.iter_mut().zip(h.force_n) {
                    *load -= lever * force / (h.stiffness_n_per_m * compliance);
                }
            }
            let sol = self.contact.solve(
                &mut self.contact_state,
                body,
                rigid_tissue.y,
                compliance,
                loads,
                dt,
            );
            if let Some(h) = &mut self.incision {
                // The pivot carries the tip's lateral load through the lever; its spring
                // takes what the friction element does not.
                let tip_load = [sol.friction_n[0] + other[0], sol.friction_n[1] + other[1]];
                let shift = [
                    (lever * tip_load[0] - h.force_n[0]) / h.stiffness_n_per_m,
                    (lever * tip_load[1] - h.force_n[1]) / h.stiffness_n_per_m,
                ];
                h.update(shift);
            }
            self.normal_n = sol.normal_n;
            self.indentation_m = sol.indentation_m;
            self.friction_n = sol.friction_n;
            self.sliding = sol.sliding;
            let contact_at = SurfacePoint::new(sol.position[0], sol.position[1]);
            (self.sensor, self.patch_centre, self.attitude) = match self.pin {
                None => (contact_at, None, Attitude::default()),
                Some(PinAxis::AlongLine) => (
                    contact_at,
                    None,
                    Attitude {
                        line_tilt_rad: across,
                        pin_height_m: r,
                        ..Attitude::default()
                    },
                ),
                // The strip turns with the rod about the body's axis: it senses r sin α
                // along x from the bottom of the cylinder, where the patch is.
                Some(PinAxis::AcrossLine) => (
                    SurfacePoint::new(contact_at.x_m + r * along.sin(), contact_at.z_m),
                    Some(contact_at),
                    Attitude {
                        strip_angle_rad: along,
                        line_friction_n: sol.friction_n[1],
                        rocking: true,
                        pin_height_m: r,
                        ..Attitude::default()
                    },
                ),
            };
            self.rigid_sensor = SurfacePoint::new(rigid[0], rigid[1]);
            self.height_m = rigid_tissue.y;
            let tip_force =
                base_from_tissue * Vector3::new(sol.friction_n[0], sol.normal_n, sol.friction_n[1]);
            let f_gimbal = self.rod.gimbal_force(&geom, &tip_force);
            let rod_tau = jac.transpose() * f_gimbal;
            for i in 0..3 {
                tau[i] += rod_tau[i];
            }
            let (axial, lateral) = self.rod.reflected_mass_kg(geom.gimbal_to_pivot_m);
            let uu = geom.axis * geom.axis.transpose();
            let m_gimbal = uu * axial + (Matrix3::identity() - uu) * lateral;
            extra = jac.transpose() * m_gimbal * jac;
        }
        if !self.held {
            self.joints.step(&tau, &extra, dt);
        }
        self.encoders.sample(&self.joints.q, dt);
    }
}

#[cfg(test)]
#[path = "bench_tests.rs"]
mod tests;
