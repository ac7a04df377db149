//! The scene file's types. Every field is SI with a unit suffix; optional sections are
//! effects that exist only when named.

use control::frames::{SurfacePoint, TissuePlacement};
use control::kinematics::PhantomGeometry;
use control::pd::gravity::PhantomMasses;
use serde::{Deserialize, Serialize};

use super::path::PathSpec;
use super::pulse::PulseSpec;

/// A whole scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Scene", deny_unknown_fields)]
pub struct Scene {
    pub version: u32,
    /// Short name used in reports (`seed-arc-145`).
    pub name: String,
    /// What the scene reproduces or studies.
    #[serde(default)]
    pub description: String,
    pub artery: ArterySpec,
    pub pulse: PulseSpec,
    #[serde(default)]
    pub tissue: TissueSpec,
    /// Buried lumps that do not pulse (tumours, nodules).
    #[serde(default)]
    pub lumps: Vec<LumpSpec>,
    #[serde(default)]
    pub sensor: SensorSpec,
    /// The rod's bending; absent: a rigid rod.
    #[serde(default)]
    pub shaft: Option<ShaftSpec>,
    /// The incision's compliance and true position; absent: a rigid pivot exactly where the
    /// configuration says.
    #[serde(default)]
    pub pivot: Option<PivotSpec>,
    /// The mass hung on the shaft above the sensor; absent: none.
    #[serde(default)]
    pub mass: Option<MassSpec>,
    /// The Phantom's dynamics; absent: the lockstep runner uses an ideal kinematic robot (the
    /// sensor is exactly where the motion planner says) and the daemon's rig uses the
    /// defaults of [`RobotSpec`].
    #[serde(default)]
    pub robot: Option<RobotSpec>,
    #[serde(default)]
    pub faults: Option<FaultSpec>,
    /// The surgeon's two manual placements of the sensor centre, tissue frame, written as a
    /// list of two points.
    #[serde(deserialize_with = "two_points", serialize_with = "two_points_out")]
    pub placements: [SurfacePoint; 2],
    /// How much artery to follow, and why that much.
    pub track: TrackSpec,
    /// Where the sensor centre rests on the tissue before the trial; default 1 cm before the
    /// first placement along `-x`.
    #[serde(default)]
    pub start: Option<SurfacePoint>,
    /// How the surgeon puts the sensor on each placement (default: by commanding the robot).
    #[serde(default)]
    pub placed_by: Placing,
    /// Someone holds the instrument at `start` until the arm is first powered, as an operator
    /// does on a rig whose unpowered arm would not rest there: with the added mass off, the
    /// links' weight lifts the tip off the tissue and the arm falls against its stops, where
    /// it may not be enabled. Default false: the arm rests at `start` on its own (the mass
    /// presses the sensor into the tissue).
    #[serde(default)]
    pub held_until_enabled: bool,
    /// The joints' errors the joints calibration removes (docs/rig-bring-up.md section 1);
    /// absent: encoders that read the true angles and stops 0.05 rad outside the configured
    /// software limits.
    #[serde(default)]
    pub joints: Option<JointErrorsSpec>,
}

/// The arm's encoder zero and mechanical stops as they truly are.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointErrorsSpec {
    /// The encoders read the true angle plus this (the arm was powered up away from the
    /// pose the config's `zero_offset_rad` describes), rad.
    pub encoder_zero_error_rad: [f64; 3],
    /// How far each joint's (lower, upper) mechanical stop lies beyond the configured
    /// software limit, rad; negative: inside it.
    pub stop_beyond_limit_rad: [[f64; 2]; 3],
    /// The arm starts in the reset pose (`calibration.joints.reset_pose_rad`, true angles)
    /// with the instrument out of the incision (no rod, no tissue contact), held against
    /// its reset fixture until it is first powered.
    pub start_at_reset: bool,
}

impl Default for JointErrorsSpec {
    fn default() -> Self {
        Self {
            encoder_zero_error_rad: [0.0; 3],
            stop_beyond_limit_rad: [[DEFAULT_STOP_BEYOND_LIMIT_RAD; 2]; 3],
            start_at_reset: false,
        }
    }
}

/// Where the simulated stops lie beyond the configured software limits unless a scene says.
pub const DEFAULT_STOP_BEYOND_LIMIT_RAD: f64 = 0.05;

/// How the surgeon puts the sensor on a placement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Placing {
    /// Commands the robot to the mark: the robot's belief lands on it, and the sensor itself
    /// trails by the rod's compliance.
    #[default]
    Robot,
    /// Slides the sensor onto the mark watching the sensor itself: it lands on the mark and
    /// the robot's belief is ahead of it by the compliance lag, along the approach.
    Eye,
}

/// The artery (or the seed's latex tube).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArterySpec {
    pub path: PathSpec,
    /// Depth of the lumen's centre below the surface at the path's start, m.
    pub depth_m: f64,
    /// Depth at the path's end (linear in arc length between); default: constant.
    #[serde(default)]
    pub depth_end_m: Option<f64>,
    /// Inner (lumen) radius at the start, m.
    pub inner_radius_m: f64,
    /// Inner radius at the end; default: constant.
    #[serde(default)]
    pub inner_radius_end_m: Option<f64>,
    /// Wall thickness, m (sets the outer radius; the lumen pressure is taken as transmitted
    /// through the wall, see docs/calibration.md).
    pub wall_m: f64,
    /// Which surface pressure kernel the tactile model uses (default: the analytic one).
    #[serde(default)]
    pub kernel: PressureKernel,
    /// How the pulse couples into each element against its local hold-down pressure
    /// (default: linearly, independent of it).
    #[serde(default)]
    pub coupling: PulseCoupling,
}

/// How the pulse reaches each element against the sensor's local hold-down pressure.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum PulseCoupling {
    /// The kernel as it is: linear elasticity, independent of the hold-down.
    #[default]
    Linear,
    /// The seed's vented tube: between pulses it is squeezed oval by the sensor's load and
    /// each pulse re-rounds it, so the pulse an element feels scales with the local contact
    /// pressure over the tube. It equals the kernel's when the sensor lies level under
    /// `reference_normal_n` (docs/calibration.md).
    HoldDown { reference_normal_n: f64 },
}

/// The surface pressure kernel of the tube.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum PressureKernel {
    /// DESIGN.md section 5: 2 Δp a² (h² - u²)/(u² + h²)², wall-less and modulus-free.
    #[default]
    Analytic,
    /// From the 2-D FEM (`pulsetrack_fem::kernel`) for the artery's depth, radius and wall and
    /// these moduli, cached on disk (`$PULSETRACK_FEM_CACHE` or the temporary directory).
    /// Needs a constant depth and radius along the path.
    Fem(pulsetrack_fem::kernel::FemKernelSpec),
    /// The artery flattened against bone by the sensor (applanation): over half its outer
    /// circumference the lumen pressure acts on the tissue above it directly and spreads
    /// through the cover to the sensor (`physics::applanation`).
    Applanation,
}

/// The tissue (or foam) the sensor slides on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TissueSpec {
    /// Normal contact stiffness under the sensor body, N/m.
    pub contact_stiffness_n_per_m: f64,
    /// Normal contact damping, N·s/m.
    pub contact_damping_n_s_per_m: f64,
    /// Sliding friction; absent: frictionless.
    pub friction: Option<FrictionSpec>,
    /// The tissue (artery and lumps with it) moving with breathing; absent: at rest.
    pub breathing: Option<Breathing>,
    /// Where the tissue truly lies against where the config's `robot.tissue` says: the error
    /// a tissue-frame calibration removes. Absent: where the config says.
    pub placement_error: Option<PlacementError>,
}

impl Default for TissueSpec {
    fn default() -> Self {
        Self {
            contact_stiffness_n_per_m: 1000.0,
            contact_damping_n_s_per_m: 15.0,
            friction: None,
            breathing: None,
            placement_error: None,
        }
    }
}

impl TissueSpec {
    /// Where the tissue truly lies, for the config's `configured` placement.
    pub fn true_placement(&self, configured: &TissuePlacement) -> TissuePlacement {
        match &self.placement_error {
            None => *configured,
            Some(e) => TissuePlacement {
                origin_in_base_m: std::array::from_fn(|i| {
                    configured.origin_in_base_m[i] + e.origin_offset_m[i]
                }),
                yaw_rad: configured.yaw_rad + e.yaw_rad,
            },
        }
    }
}

/// The true tissue placement minus the configured one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlacementError {
    /// Added to the configured yaw, rad.
    pub yaw_rad: f64,
    /// Added to the configured origin, robot base frame, m (`y` up: a surface higher than
    /// configured).
    pub origin_offset_m: [f64; 3],
}

impl Default for PlacementError {
    fn default() -> Self {
        Self {
            yaw_rad: 0.0,
            origin_offset_m: [0.0; 3],
        }
    }
}

/// The tissue moving with breathing: the artery and the lumps are displaced, rigidly in the
/// tissue plane, by `amplitude_m · sin(2π frequency_hz · t + phase_rad)` along
/// `direction_rad` (0: along `+x`, π/2: along `+z`). The sensor's contact and friction are
/// not dragged with it (the tissue slides under the sensor), and a located point is scored
/// against the artery where it was at the time of the fix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Breathing {
    /// Peak displacement, m.
    pub amplitude_m: f64,
    pub frequency_hz: f64,
    #[serde(default = "across_x")]
    pub direction_rad: f64,
    #[serde(default)]
    pub phase_rad: f64,
}

fn across_x() -> f64 {
    std::f64::consts::FRAC_PI_2
}

impl Breathing {
    /// The tissue's displacement at `t_s` (x, z), m.
    pub fn displacement_m(&self, t_s: f64) -> [f64; 2] {
        let a = self.amplitude_m
            * (2.0 * std::f64::consts::PI * self.frequency_hz * t_s + self.phase_rad).sin();
        [a * self.direction_rad.cos(), a * self.direction_rad.sin()]
    }

    /// `p` moved into the resting tissue's frame at `t_s` (the displacement taken off).
    pub fn to_rest(&self, p: SurfacePoint, t_s: f64) -> SurfacePoint {
        let d = self.displacement_m(t_s);
        SurfacePoint::new(p.x_m - d[0], p.z_m - d[1])
    }
}

/// Coulomb friction between the sensor and the tissue, with the tissue surface's shear
/// compliance before sliding (an elasto-plastic contact).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    pub static_coefficient: f64,
    pub kinetic_coefficient: f64,
    /// Tangential stiffness of the contact before it slides, N/m.
    #[serde(default = "default_shear_stiffness")]
    pub shear_stiffness_n_per_m: f64,
}

fn default_shear_stiffness() -> f64 {
    2000.0
}

/// A buried lump that does not pulse: a static bump in the contact pressure over it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LumpSpec {
    pub centre: SurfacePoint,
    /// Depth of its centre, m.
    pub depth_m: f64,
    /// Peak extra contact pressure directly above it, as a fraction of the mean contact
    /// pressure (a stiff inclusion concentrates the load).
    pub pressure_gain: f64,
}

/// The tactile sensor (truth). The robot's belief about the array (pitch, direction, noise
/// SD used by trackers) is the configuration's `sensor` section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// Element centre spacing along tissue `z`, m.
    pub pitch_m: f64,
    /// Sensing area of one element, m² (its width along `z` is the pitch).
    pub element_area_m2: f64,
    /// Noise SD of each element, N.
    pub noise_sd_n: f64,
    /// The sensor body: a cylinder lying along tissue `z` whose bottom edge carries the
    /// elements.
    pub body_length_m: f64,
    pub body_diameter_m: f64,
    /// From the body's distal end to the near edge of element 0, m.
    pub distal_margin_m: f64,
    /// How the body hangs on the rod's end (the seed's pin joint); absent: level and
    /// directly under the rod's tip, as the robot's model assumes.
    pub mount: Option<MountSpec>,
}

/// The sensor body's pin joint at the rod's end. The pin sits on the body's axis above the
/// element line's centre (where the robot's model puts the tip).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountSpec {
    pub pin: PinAxis,
}

/// Which way the pin runs, relative to the element line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PinAxis {
    /// Along the line: the body swings freely as the rod tilts along the artery, keeping
    /// the elements down, but tilts with the rod sideways: the element line tilts against
    /// the tissue by the rod's lateral tilt (one end presses harder, the other may lift) and
    /// its centre moves sideways by `r sin β`.
    AlongLine,
    /// Across the line: the body rocks freely in the line's plane (its load centre stays
    /// under the pin, the pulse cannot tilt it), but turns with the rod's tilt along the
    /// artery about its own axis, which carries the element strip off the bottom of the
    /// cylinder by that angle (`r sin α` along the artery, less load).
    AcrossLine,
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            pitch_m: 0.002,
            element_area_m2: 4.0e-6,
            noise_sd_n: 0.012,
            body_length_m: 0.034,
            body_diameter_m: 0.009,
            distal_margin_m: 0.001,
            mount: None,
        }
    }
}

/// The rod's bending stiffness.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShaftSpec {
    pub diameter_m: f64,
    pub youngs_modulus_pa: f64,
    /// Material density, kg/m³ (for the rod's weight).
    #[serde(default = "steel_density")]
    pub density_kg_m3: f64,
    /// True rod length if it differs from the configuration's, m.
    #[serde(default)]
    pub length_m: Option<f64>,
}

fn steel_density() -> f64 {
    7850.0
}

/// The incision.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PivotSpec {
    /// True pivot minus the configured one, robot base frame, m.
    pub offset_m: [f64; 3],
    /// Lateral stiffness of the incision point, N/m; absent: rigid.
    pub lateral_stiffness_n_per_m: Option<f64>,
    /// Dry-friction hysteresis of a rubber or foam incision: a friction element (as stiff as
    /// the incision, in parallel with it) that slips at this force, N; absent: a linear
    /// spring. Needs `lateral_stiffness_n_per_m`.
    pub hysteresis_slip_n: Option<f64>,
}

impl Default for PivotSpec {
    fn default() -> Self {
        Self {
            offset_m: [0.0; 3],
            lateral_stiffness_n_per_m: None,
            hysteresis_slip_n: None,
        }
    }
}

/// The mass hung on the shaft for contact force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassSpec {
    pub mass_kg: f64,
    /// How far above the rod tip it hangs, m.
    #[serde(default = "mass_height")]
    pub height_above_tip_m: f64,
}

fn mass_height() -> f64 {
    0.03
}

/// The Phantom's true dynamics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotSpec {
    /// True link lengths if they differ from the configuration's.
    pub phantom: Option<PhantomGeometry>,
    /// Inertia about each joint (motor and capstan reflected, links), kg·m².
    pub joint_inertia_kg_m2: [f64; 3],
    /// Coulomb friction at each joint, N·m.
    pub coulomb_friction_nm: [f64; 3],
    /// Viscous friction at each joint, N·m·s/rad.
    pub viscous_friction_nm_s: [f64; 3],
    /// The arm's moving bodies as gravity sees them; absent: the same as the controller's
    /// gravity model believes (control's documented Phantom 1.5 values).
    pub masses: Option<PhantomMasses>,
    /// Encoder counts per motor revolution.
    pub encoder_counts_per_rev: f64,
    /// Capstan reduction per joint.
    pub capstan_ratio: [f64; 3],
    /// Time constant of the velocity estimate from encoder differences, s.
    pub velocity_filter_s: f64,
    /// Largest torque the amplifiers deliver at each joint, N·m.
    pub torque_saturation_nm: [f64; 3],
}

impl Default for RobotSpec {
    fn default() -> Self {
        Self {
            phantom: None,
            joint_inertia_kg_m2: [0.0040, 0.0020, 0.0010],
            coulomb_friction_nm: [0.012, 0.010, 0.010],
            viscous_friction_nm_s: [0.002, 0.002, 0.002],
            masses: None,
            encoder_counts_per_rev: 1024.0,
            capstan_ratio: [13.3, 11.2, 11.2],
            velocity_filter_s: 0.005,
            torque_saturation_nm: [1.2, 1.0, 1.0],
        }
    }
}

/// Faults injected into the bench.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultSpec {
    /// Elements that read only noise.
    pub dead_elements: Vec<usize>,
    /// Probability that a tactile frame is lost (a gap in `seq`).
    pub frame_drop_probability: f64,
    /// Each element's gain (reading per newton), element 0 first: the sensitivity spread the
    /// tactile calibration measures. Empty: every gain 1.
    pub element_gains: Vec<f64>,
    /// Each element's reading at no load, N, element 0 first: what the tare removes.
    /// Empty: 0 N.
    pub element_offsets_n: Vec<f64>,
}

impl Default for FaultSpec {
    fn default() -> Self {
        Self {
            dead_elements: Vec::new(),
            frame_drop_probability: 0.0,
            element_gains: Vec::new(),
            element_offsets_n: Vec::new(),
        }
    }
}

/// How much artery a trial follows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackSpec {
    /// Path length to follow from the first placement, m.
    pub length_m: f64,
    /// Why this length (e.g. where the artery turns too far toward the element line).
    pub reason: String,
}

fn two_points<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[SurfacePoint; 2], D::Error> {
    let points = Vec::<SurfacePoint>::deserialize(d)?;
    let n = points.len();
    <[SurfacePoint; 2]>::try_from(points)
        .map_err(|_| serde::de::Error::custom(format!("expected exactly two placements, got {n}")))
}

/// The placements as the list the loader reads.
fn two_points_out<S: serde::Serializer>(p: &[SurfacePoint; 2], s: S) -> Result<S::Ok, S::Error> {
    p.as_slice().serialize(s)
}
