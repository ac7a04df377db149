//! A one-dimensional trapezoidal (acceleration-limited) profile over a distance.
//!
//! Accelerate at `a` to the cruise speed `v`, cruise, decelerate at `a` to rest. When the
//! distance is shorter than `v²/a` the cruise phase vanishes and the peak speed is `√(D a)`
//! (a triangle).

/// Position and speed along the path at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileSample {
    /// Distance travelled, m, within `[0, distance]`.
    pub s_m: f64,
    /// Speed along the path, m/s, never negative.
    pub speed_m_s: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trapezoid {
    distance_m: f64,
    accel_m_s2: f64,
    peak_m_s: f64,
    /// Duration of the acceleration (and of the deceleration) phase, s.
    ramp_s: f64,
    /// Duration of the cruise phase, s.
    cruise_s: f64,
}

impl Trapezoid {
    /// Callers guarantee `distance_m >= 0` and positive finite speed and acceleration.
    pub(crate) fn new(distance_m: f64, speed_m_s: f64, accel_m_s2: f64) -> Self {
        let (peak_m_s, ramp_s, cruise_s) = if distance_m * accel_m_s2 >= speed_m_s * speed_m_s {
            let ramp_s = speed_m_s / accel_m_s2;
            (
                speed_m_s,
                ramp_s,
                (distance_m - speed_m_s * ramp_s) / speed_m_s,
            )
        } else {
            let peak = (distance_m * accel_m_s2).sqrt();
            (peak, peak / accel_m_s2, 0.0)
        };
        Self {
            distance_m,
            accel_m_s2,
            peak_m_s,
            ramp_s,
            cruise_s,
        }
    }

    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Highest speed reached, m/s.
    pub fn peak_speed_m_s(&self) -> f64 {
        self.peak_m_s
    }

    pub fn duration_s(&self) -> f64 {
        2.0 * self.ramp_s + self.cruise_s
    }

    /// The profile `t` seconds after its start (clamped to the start and to the end).
    pub fn sample(&self, t: f64) -> ProfileSample {
        let a = self.accel_m_s2;
        let total = self.duration_s();
        if t <= 0.0 || total <= 0.0 {
            return ProfileSample {
                s_m: 0.0,
                speed_m_s: 0.0,
            };
        }
        if t >= total {
            return ProfileSample {
                s_m: self.distance_m,
                speed_m_s: 0.0,
            };
        }
        let ramp_distance = 0.5 * a * self.ramp_s * self.ramp_s;
        let (s_m, speed_m_s) = if t < self.ramp_s {
            (0.5 * a * t * t, a * t)
        } else if t < self.ramp_s + self.cruise_s {
            let tc = t - self.ramp_s;
            (ramp_distance + self.peak_m_s * tc, self.peak_m_s)
        } else {
            let left = total - t;
            (self.distance_m - 0.5 * a * left * left, a * left)
        };
        ProfileSample {
            s_m: s_m.clamp(0.0, self.distance_m),
            speed_m_s,
        }
    }
}
