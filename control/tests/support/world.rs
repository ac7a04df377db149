//! A scripted fake world for tracker tests: an artery path under the tissue surface, a
//! pulsing pressure, the tactile array's frames wherever the sensor is, and a simple
//! motion layer that carries out `MoveTo` at the commanded speed.
//!
//! Each element's force is the surface-pressure kernel of DESIGN.md section 5 integrated
//! over the element's 2 mm along `z`, evaluated at the perpendicular distance from the
//! artery axis (so an oblique crossing widens the footprint), times the pulse, plus contact
//! force and noise. Where the path has a gap, or beyond its end, nothing pulses.

use control::frames::SurfacePoint;
use control::sensor::ArrayGeometry;
use control::tracker::{MotionCommand, Tracker, TrackerEvent, TrackerInput};
use control::types::{ELEMENTS, TactileFrame};

use super::synth::Rng;

/// The artery's course, from its start: a polyline, or a circular arc.
#[derive(Debug, Clone)]
pub enum ArteryPath {
    Polyline {
        vertices: Vec<SurfacePoint>,
        length_m: f64,
    },
    /// From the origin heading +x, turning toward +z.
    Arc { radius_m: f64, length_m: f64 },
}

impl ArteryPath {
    pub fn polyline(vertices: Vec<SurfacePoint>) -> Self {
        assert!(vertices.len() >= 2);
        let length_m = vertices.windows(2).map(|w| w[0].distance_to(&w[1])).sum();
        Self::Polyline { vertices, length_m }
    }

    /// Straight from `start` along `heading_rad` (from +x toward +z) for `length_m`.
    pub fn straight(start: SurfacePoint, heading_rad: f64, length_m: f64) -> Self {
        let end = SurfacePoint::new(
            start.x_m + length_m * heading_rad.cos(),
            start.z_m + length_m * heading_rad.sin(),
        );
        Self::polyline(vec![start, end])
    }

    /// A circular arc from the origin heading +x, turning toward +z.
    pub fn arc(radius_m: f64, length_m: f64) -> Self {
        Self::Arc { radius_m, length_m }
    }

    /// Distance from `p` to the path and the arc length at the nearest point (clamped to
    /// the ends).
    pub fn nearest(&self, p: &SurfacePoint) -> (f64, f64) {
        match self {
            Self::Polyline { vertices, .. } => {
                let mut best = (f64::INFINITY, 0.0);
                let mut s0 = 0.0;
                for w in vertices.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    let (dx, dz) = (b.x_m - a.x_m, b.z_m - a.z_m);
                    let len = dx.hypot(dz);
                    let u = (((p.x_m - a.x_m) * dx + (p.z_m - a.z_m) * dz) / (len * len))
                        .clamp(0.0, 1.0);
                    let foot = SurfacePoint::new(a.x_m + u * dx, a.z_m + u * dz);
                    let d = foot.distance_to(p);
                    if d < best.0 {
                        best = (d, s0 + u * len);
                    }
                    s0 += len;
                }
                best
            }
            &Self::Arc { radius_m, length_m } => {
                // Centre at (0, R); the start is at angle -π/2 from it.
                let (dx, dz) = (p.x_m, p.z_m - radius_m);
                let angle = dz.atan2(dx) + std::f64::consts::FRAC_PI_2;
                let angle = angle.rem_euclid(2.0 * std::f64::consts::PI);
                let s = (angle * radius_m).min(length_m);
                let s = if angle * radius_m
                    > length_m + (2.0 * std::f64::consts::PI * radius_m - length_m) / 2.0
                {
                    0.0
                } else {
                    s
                };
                (self.at(s).distance_to(p), s)
            }
        }
    }

    pub fn length_m(&self) -> f64 {
        match self {
            Self::Polyline { length_m, .. } | Self::Arc { length_m, .. } => *length_m,
        }
    }

    /// The point at arc length `s`.
    pub fn at(&self, s: f64) -> SurfacePoint {
        match self {
            Self::Polyline { vertices, .. } => {
                let mut left = s;
                for w in vertices.windows(2) {
                    let len = w[0].distance_to(&w[1]);
                    if left <= len {
                        let u = left / len;
                        return SurfacePoint::new(
                            w[0].x_m + u * (w[1].x_m - w[0].x_m),
                            w[0].z_m + u * (w[1].z_m - w[0].z_m),
                        );
                    }
                    left -= len;
                }
                *vertices.last().expect("at least two vertices")
            }
            &Self::Arc { radius_m, .. } => {
                let a = s / radius_m;
                SurfacePoint::new(radius_m * a.sin(), radius_m * (1.0 - a.cos()))
            }
        }
    }
}

/// The pulsing artery and the sensor that feels it.
#[derive(Debug, Clone)]
pub struct World {
    pub path: ArteryPath,
    /// Arc-length ranges where the artery does not pulse (e.g. it dives deep), m.
    pub gaps: Vec<(f64, f64)>,
    /// Swing of an element centred over the artery, N.
    pub swing_n: f64,
    pub rate_hz: f64,
    pub depth_m: f64,
    pub noise_sd_n: f64,
    pub geometry: ArrayGeometry,
    /// The tissue (artery and all) moving across `z` as breathing moves it: amplitude m,
    /// frequency Hz, phase rad; zero amplitude: at rest.
    pub breathing: (f64, f64, f64),
    rng: Rng,
    seq: u64,
}

impl World {
    /// The seed's bench: a 1 Hz solenoid square wave, tube 5 mm deep, 0.06 N swing (the
    /// seed's "up to 0.06 N"), 0.012 N noise.
    pub fn seed_bench(path: ArteryPath, seed: u64) -> Self {
        Self {
            path,
            gaps: Vec::new(),
            swing_n: 0.06,
            rate_hz: 1.0,
            depth_m: 0.005,
            noise_sd_n: 0.012,
            geometry: ArrayGeometry::default(),
            breathing: (0.0, 0.0, 0.0),
            rng: Rng::new(seed),
            seq: 0,
        }
    }

    pub fn t_s(&self) -> f64 {
        self.seq as f64 * self.geometry.dt_s()
    }

    /// How far the tissue has moved across `z` at `t`, m.
    pub fn tissue_shift_m(&self, t: f64) -> f64 {
        let (a, f, phase) = self.breathing;
        a * (std::f64::consts::TAU * f * t + phase).sin()
    }

    /// Smoothed square wave in 0..1 (the solenoid inflating and venting the tube).
    fn pulse(&self, t: f64) -> f64 {
        0.5 + 0.5 * (6.0 * (2.0 * std::f64::consts::PI * self.rate_hz * t).sin()).tanh()
    }

    /// Kernel p(d) of DESIGN.md section 5, up to its constant factor.
    fn kernel(&self, d: f64) -> f64 {
        let h2 = self.depth_m * self.depth_m;
        (h2 - d * d) / ((d * d + h2) * (d * d + h2))
    }

    /// The kernel integrated over one element (midpoint rule, 16 strips along `z`), with
    /// no pulse where the path has a gap or has ended.
    fn element_gain(&self, centre: &SurfacePoint) -> f64 {
        const STRIPS: usize = 16;
        let pitch = self.geometry.pitch_m;
        let mut sum = 0.0;
        for k in 0..STRIPS {
            let dz = ((k as f64 + 0.5) / STRIPS as f64 - 0.5) * pitch;
            let p = SurfacePoint::new(centre.x_m, centre.z_m + dz);
            let (d, s) = self.path.nearest(&p);
            // Nearest to an end point means beyond the artery's ends: nothing there.
            let pulsing = s > 0.0
                && s < self.path.length_m()
                && !self.gaps.iter().any(|&(a, b)| s >= a && s <= b);
            if pulsing {
                sum += self.kernel(d);
            }
        }
        sum / STRIPS as f64 / self.centred_gain()
    }

    fn centred_gain(&self) -> f64 {
        const STRIPS: usize = 16;
        let pitch = self.geometry.pitch_m;
        (0..STRIPS)
            .map(|k| self.kernel(((k as f64 + 0.5) / STRIPS as f64 - 0.5) * pitch))
            .sum::<f64>()
            / STRIPS as f64
    }

    /// The next frame with the sensor centre at `sensor`.
    pub fn frame(&mut self, sensor: &SurfacePoint) -> TactileFrame {
        let t_s = self.t_s();
        let pulse = self.pulse(t_s);
        // The tissue moving by `shift` is the sensor moving by `-shift` over still tissue.
        let shift = self.tissue_shift_m(t_s);
        let mut force_n = [0.0; ELEMENTS];
        for (e, f) in force_n.iter_mut().enumerate() {
            let centre = SurfacePoint::new(
                sensor.x_m,
                sensor.z_m - shift + self.geometry.offset_z_m(e as f64),
            );
            *f = 0.4
                + self.swing_n * pulse * self.element_gain(&centre)
                + self.noise_sd_n * self.rng.normal();
        }
        let frame = TactileFrame {
            t_s,
            seq: self.seq,
            force_n,
        };
        self.seq += 1;
        frame
    }
}

/// A motion layer that moves the sensor straight to the commanded target at the commanded
/// speed and reports `settled` once it is there.
#[derive(Debug, Clone)]
pub struct Mover {
    pub position: SurfacePoint,
    target: Option<(SurfacePoint, f64)>,
    /// Distance travelled, m.
    pub travelled_m: f64,
}

impl Mover {
    pub fn at(position: SurfacePoint) -> Self {
        Self {
            position,
            target: None,
            travelled_m: 0.0,
        }
    }

    pub fn settled(&self) -> bool {
        self.target.is_none()
    }

    pub fn command(&mut self, motion: &MotionCommand) {
        if let MotionCommand::MoveTo { target, speed_m_s } = *motion
            && target.distance_to(&self.position) > 0.0
        {
            self.target = Some((target, speed_m_s));
        }
    }

    pub fn advance(&mut self, dt_s: f64) {
        if let Some((target, speed)) = self.target {
            let d = self.position.distance_to(&target);
            let reach = speed * dt_s;
            if d <= reach {
                self.travelled_m += d;
                self.position = target;
                self.target = None;
            } else {
                let u = reach / d;
                self.position = SurfacePoint::new(
                    self.position.x_m + u * (target.x_m - self.position.x_m),
                    self.position.z_m + u * (target.z_m - self.position.z_m),
                );
                self.travelled_m += reach;
            }
        }
    }
}

/// What a run saw.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Every event, in order.
    pub events: Vec<TrackerEvent>,
    /// Every distinct `MoveTo` target, in the order first commanded.
    pub targets: Vec<SurfacePoint>,
    /// Frames stepped.
    pub frames: usize,
}

/// Drive a tracker in the world until `until` accepts an event or `max_frames` pass.
pub fn run(
    tracker: &mut dyn Tracker,
    world: &mut World,
    mover: &mut Mover,
    max_frames: usize,
    mut until: impl FnMut(&TrackerEvent) -> bool,
) -> Trace {
    let mut trace = Trace::default();
    let dt = world.geometry.dt_s();
    for _ in 0..max_frames {
        let frame = world.frame(&mover.position);
        let out = tracker.step(&TrackerInput {
            frame: &frame,
            sensor: mover.position,
            settled: mover.settled(),
            loaded_sensor: None,
        });
        trace.frames += 1;
        if let MotionCommand::MoveTo { target, .. } = out.motion
            && trace.targets.last() != Some(&target)
        {
            trace.targets.push(target);
        }
        mover.command(&out.motion);
        mover.advance(dt);
        if let Some(e) = out.event {
            trace.events.push(e);
            if until(&e) {
                break;
            }
        }
    }
    trace
}
