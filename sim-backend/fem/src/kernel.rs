//! The simulator's pressure kernel from the FEM, cached on disk.
//!
//! The kernel is the change of contact pressure on a rigid flat sensor held on the surface
//! (frictionless, u_y = 0 on the top) per unit lumen pressure, against the lateral distance
//! from the tube's axis, in plane strain (a long tube). The analytic kernel of DESIGN.md
//! section 5, p(x) = 2 Δp a² (h² - x²)/(x² + h²)², is its limit for a wall-less hole with
//! a << h in a half-space; the FEM adds the wall, a finite hole, finite depth and moduli.
//!
//! Cache files are RON named by a deterministic key (FNV-1a of the parameters and the
//! solver's tag). A file is used only if it parses, names the same solver and the very
//! same parameters, and its checksum and samples are consistent; anything else is
//! recomputed and rewritten (write to a temporary file, then rename).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use config::{Validate, Validator};

use super::material::{Analysis, Material};
use super::model::{
    Block, Bottom, FeatureSpec, Kinematics, LayerSpec, Load, LumenPressure, MeshSpec, ModelFile,
};
use super::recovery::interpolate;
use super::run::{FemError, run_model};

/// Changes whenever the solver or the kernel's definition changes (invalidates caches).
pub const SOLVER_TAG: &str = "pulsetrack-fem-q4-bbar-kernel-v2";

/// What a kernel depends on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KernelParams {
    pub tissue: Material,
    /// Inner radius of the tube, m.
    pub lumen_radius_m: f64,
    /// Wall thickness (0 for a hole in the tissue) and material.
    pub wall_thickness_m: f64,
    pub wall: Material,
    /// Depth of the tube's axis below the surface, m.
    pub centre_depth_m: f64,
    /// Mesh refinement levels beyond the kernel's default density.
    pub refine: u32,
    /// Depth below the surface of a rigid, frictionless backing the tissue rests on (bone
    /// under the radial artery; the table under a foam sheet), m. Absent: the block hangs
    /// from the surface (the half-space stand-in, zero net surface force). Left out of the
    /// serialized form when absent, so the cache keys of kernels without one are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backing_depth_m: Option<f64>,
}

impl KernelParams {
    pub fn outer_radius_m(&self) -> f64 {
        self.lumen_radius_m + self.wall_thickness_m
    }

    pub fn is_valid(&self) -> bool {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        self.tissue.is_valid()
            && self.wall.is_valid()
            && pos(self.lumen_radius_m)
            && self.wall_thickness_m.is_finite()
            && self.wall_thickness_m >= 0.0
            && pos(self.centre_depth_m)
            && self.centre_depth_m >= 1.2 * self.outer_radius_m()
            && self.refine <= 3
            && self.backing_depth_m.is_none_or(|b| {
                b.is_finite() && b >= self.centre_depth_m + 1.2 * self.meshed_radius_m()
            })
    }

    /// The outermost meshed circle: the wall, or for a hole the ring of tissue that stands
    /// in for it ([`Self::model`]). The mesher needs 1.15 of it to every edge.
    pub fn meshed_radius_m(&self) -> f64 {
        if self.wall_thickness_m > 0.0 {
            self.outer_radius_m()
        } else {
            1.25 * self.lumen_radius_m
        }
    }

    /// The FEM model: a block 24 depths wide and 8 deep hanging from a flat rigid surface
    /// (bottom and sides free, so that, as in a half-space, the surface carries no net
    /// force), 1 Pa in the lumen. With a backing the block is exactly as deep as the backing
    /// and its bottom is held in y (frictionless): the tube can no longer relieve itself
    /// downward, and the surface carries a net force.
    pub fn model(&self) -> ModelFile {
        let h = self.centre_depth_m;
        let r = self.outer_radius_m();
        let width = (24.0 * h).max(0.06);
        let (height, bottom) = match self.backing_depth_m {
            Some(b) => (b, Bottom::Held),
            None => ((8.0 * h).max(h + 3.0 * r), Bottom::Free),
        };
        let mut layers = Vec::new();
        let lumen = if self.wall_thickness_m > 0.0 {
            layers.push(LayerSpec {
                name: "wall".into(),
                thickness_m: self.wall_thickness_m,
                material: self.wall,
            });
            self.lumen_radius_m
        } else {
            // A hole with no wall: a thin ring of tissue stands in for the first layer
            // (`meshed_radius_m` knows its size).
            let t = 0.25 * self.lumen_radius_m;
            layers.push(LayerSpec {
                name: "tissue ring".into(),
                thickness_m: t,
                material: self.tissue,
            });
            self.lumen_radius_m
        };
        let near = (r * std::f64::consts::FRAC_PI_2 / 12.0).min(0.0004);
        ModelFile {
            version: super::model::MODEL_VERSION,
            name: "kernel".into(),
            analysis: Analysis::PlaneStrain,
            kinematics: Kinematics::Linear,
            block: Block {
                width_m: width,
                height_m: height,
            },
            tissue: self.tissue,
            feature: Some(FeatureSpec {
                centre_x_m: 0.5 * width,
                centre_depth_m: h,
                lumen_radius_m: Some(lumen),
                layers,
            }),
            load: Load::Platen { indent_m: 0.0 },
            bottom,
            lumen: Some(LumenPressure::Constant { pressure_pa: 1.0 }),
            times_s: vec![0.0],
            mesh: MeshSpec {
                near_size_m: near,
                far_size_m: (0.25 * h).clamp(near, 0.003),
                min_layer_elements: 3,
                growth: 1.15,
                refine: self.refine,
            },
            mesh_file: None,
        }
    }
}

/// A scene's choice of the FEM kernel (the tube's depth, radius and wall thickness come from
/// the scene's artery; the moduli from here).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FemKernelSpec {
    pub tissue: Material,
    pub wall: Material,
    /// Mesh refinement levels beyond the kernel's default density.
    #[serde(default)]
    pub refine: u32,
    /// A rigid, frictionless backing this far below the tube's outer wall (bone under the
    /// radial artery; the table under a foam sheet), m; absent: none. Relative to the tube,
    /// so that it follows an artery whose depth varies along its path.
    #[serde(default)]
    pub backing_gap_m: Option<f64>,
    /// The sensor has flattened the tube's wall against the backing (applanation): a flat
    /// wall carries no hoop tension, so the lumen pressure acts on the tissue directly. The
    /// kernel is then that of a hole as large as the tube's outer radius (the wall's own
    /// modulus is not used). The mesh keeps the lumen round: the flattened shape itself is
    /// not modelled, so this is the round-lumen bound of applanation (docs/calibration.md
    /// compares it with `physics::applanation`). Default false: the round wall carries its
    /// share in hoop stress.
    #[serde(default)]
    pub wall_flattened: bool,
}

impl FemKernelSpec {
    pub fn params(&self, lumen_radius_m: f64, wall_m: f64, centre_depth_m: f64) -> KernelParams {
        let (lumen_radius_m, wall_thickness_m) = if self.wall_flattened {
            (lumen_radius_m + wall_m, 0.0)
        } else {
            (lumen_radius_m, wall_m)
        };
        KernelParams {
            tissue: self.tissue,
            lumen_radius_m,
            wall_thickness_m,
            wall: self.wall,
            centre_depth_m,
            refine: self.refine,
            backing_depth_m: self
                .backing_gap_m
                .map(|g| centre_depth_m + lumen_radius_m + wall_thickness_m + g),
        }
    }
}

/// Where kernels are cached: `$PULSETRACK_FEM_CACHE`, else a directory under the system's
/// temporary directory.
pub fn default_cache_dir() -> PathBuf {
    std::env::var_os("PULSETRACK_FEM_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("pulsetrack-fem-kernels"))
}

/// Surface pressure per unit lumen pressure against lateral offset from the axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Kernel {
    pub params: KernelParams,
    /// Sorted lateral offsets, m.
    pub x_m: Vec<f64>,
    /// Compressive contact pressure change per Pa of lumen pressure (dimensionless).
    pub pressure_per_pa: Vec<f64>,
}

impl Kernel {
    /// Kernel value at offset `x_m` (linear interpolation; 0 beyond the sampled range).
    pub fn at(&self, x_m: f64) -> f64 {
        match (self.x_m.first(), self.x_m.last()) {
            (Some(&a), Some(&b)) if x_m >= a && x_m <= b => {
                interpolate(&self.x_m, &self.pressure_per_pa, x_m)
            }
            _ => 0.0,
        }
    }

    /// ∫ p dx per Pa of lumen pressure (N/m per Pa, i.e. m): zero for a half-space.
    pub fn net_force_m(&self) -> f64 {
        trapezoid(&self.x_m, &self.pressure_per_pa, false)
    }

    /// ∫ |p| dx per Pa.
    pub fn total_magnitude_m(&self) -> f64 {
        trapezoid(&self.x_m, &self.pressure_per_pa, true)
    }

    /// ∫ from the first sample to `u` of p dx (piecewise-linear p integrated exactly; p = 0
    /// outside the samples), m.
    pub fn antiderivative_m(&self, u: f64) -> f64 {
        let (x, p) = (&self.x_m, &self.pressure_per_pa);
        if x.len() < 2 || u <= x[0] {
            return 0.0;
        }
        let mut sum = 0.0;
        for k in 1..x.len() {
            if u >= x[k] {
                sum += 0.5 * (p[k - 1] + p[k]) * (x[k] - x[k - 1]);
            } else {
                let t = (u - x[k - 1]) / (x[k] - x[k - 1]);
                let pu = p[k - 1] + t * (p[k] - p[k - 1]);
                sum += 0.5 * (p[k - 1] + pu) * (u - x[k - 1]);
                break;
            }
        }
        sum
    }
}

fn trapezoid(x: &[f64], y: &[f64], abs: bool) -> f64 {
    x.windows(2)
        .zip(y.windows(2))
        .map(|(xs, ys)| {
            let (a, b) = if abs {
                (ys[0].abs(), ys[1].abs())
            } else {
                (ys[0], ys[1])
            };
            0.5 * (a + b) * (xs[1] - xs[0])
        })
        .sum()
}

/// DESIGN.md section 5's kernel per unit Δp: 2 a² (h² - x²)/(x² + h²)².
pub fn analytic_per_pa(x_m: f64, lumen_radius_m: f64, centre_depth_m: f64) -> f64 {
    let (a, h) = (lumen_radius_m, centre_depth_m);
    let d = x_m * x_m + h * h;
    2.0 * a * a * (h * h - x_m * x_m) / (d * d)
}

#[derive(Debug, Clone, thiserror::Error)]
pub enum KernelError {
    #[error(
        "invalid kernel parameters: sizes and moduli must be positive, ν in (-1, 0.5), the tube at least 1.2 outer radii deep and, with a backing, at least 1.2 meshed radii (a hole's includes a ring of 0.25 lumen radii) above it, refine <= 3"
    )]
    BadParams,
    #[error("{0}")]
    Fem(#[from] FemError),
    #[error("kernel cache {path}: {message}")]
    Io { path: String, message: String },
}

/// Compute a kernel with the FEM (no cache).
pub fn compute(params: &KernelParams) -> Result<Kernel, KernelError> {
    if !params.is_valid() {
        return Err(KernelError::BadParams);
    }
    let run = run_model(&params.model(), 0)?;
    let t = run.times.first().ok_or(KernelError::BadParams)?;
    Ok(Kernel {
        params: *params,
        x_m: t.x_m.clone(),
        pressure_per_pa: t.sigma_yy_pa.iter().map(|s| -s).collect(),
    })
}

/// FNV-1a, 64 bit (stable across builds and platforms, unlike std's hasher).
fn fnv1a(bytes: impl IntoIterator<Item = u8>, mut h: u64) -> u64 {
    for b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// Deterministic cache key of a parameter set.
pub fn cache_key(params: &KernelParams) -> String {
    let text = ron::to_string(params).unwrap_or_default();
    let h = fnv1a(SOLVER_TAG.bytes().chain(text.bytes()), FNV_OFFSET);
    format!("{h:016x}")
}

fn checksum(key: &str, x: &[f64], p: &[f64]) -> String {
    let bytes = key
        .bytes()
        .chain(x.iter().flat_map(|v| v.to_bits().to_le_bytes()))
        .chain(p.iter().flat_map(|v| v.to_bits().to_le_bytes()));
    format!("{:016x}", fnv1a(bytes, FNV_OFFSET))
}

/// The on-disk form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "FemKernelCache", deny_unknown_fields)]
struct CacheFile {
    version: u32,
    solver: String,
    key: String,
    params: KernelParams,
    x_m: Vec<f64>,
    pressure_per_pa: Vec<f64>,
    checksum: String,
}

impl Validate for CacheFile {
    fn validate(&self, v: &mut Validator) {
        v.check(self.version == 1, "version", "unsupported cache version");
        v.check(
            self.solver == SOLVER_TAG,
            "solver",
            "written by another solver version",
        );
        v.check(
            self.key == cache_key(&self.params),
            "key",
            "does not match the parameters",
        );
        v.check(
            self.x_m.len() == self.pressure_per_pa.len() && self.x_m.len() >= 3,
            "pressure_per_pa",
            "must have one value per x and at least 3 samples",
        );
        v.all_finite("x_m", &self.x_m);
        v.all_finite("pressure_per_pa", &self.pressure_per_pa);
        v.check(
            self.x_m.windows(2).all(|w| w[0] < w[1]),
            "x_m",
            "must be strictly increasing",
        );
        v.check(
            self.checksum == checksum(&self.key, &self.x_m, &self.pressure_per_pa),
            "checksum",
            "does not match the samples (corrupt file)",
        );
    }
}

/// Where a kernel came from.
#[derive(Debug, Clone, PartialEq)]
pub enum CacheStatus {
    Hit,
    /// No file yet.
    Computed,
    /// A file was there but could not be trusted; the reason.
    Recomputed(String),
}

pub fn cache_path(dir: &Path, params: &KernelParams) -> PathBuf {
    dir.join(format!("fem-kernel-{}.ron", cache_key(params)))
}

/// The kernel for `params` from `dir`, computing (and caching) it when needed.
pub fn load_or_compute(
    params: &KernelParams,
    dir: &Path,
) -> Result<(Kernel, CacheStatus), KernelError> {
    if !params.is_valid() {
        return Err(KernelError::BadParams);
    }
    let path = cache_path(dir, params);
    let status = match std::fs::read_to_string(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => CacheStatus::Computed,
        Err(e) => CacheStatus::Recomputed(format!("unreadable: {e}")),
        Ok(text) => match config::load_str::<CacheFile>(&path.display().to_string(), &text) {
            Ok(file) if file.params == *params => {
                return Ok((
                    Kernel {
                        params: file.params,
                        x_m: file.x_m,
                        pressure_per_pa: file.pressure_per_pa,
                    },
                    CacheStatus::Hit,
                ));
            }
            Ok(_) => CacheStatus::Recomputed("stale: written for other parameters".into()),
            Err(e) => CacheStatus::Recomputed(e.to_string()),
        },
    };
    let kernel = compute(params)?;
    write_cache(&path, &kernel)?;
    Ok((kernel, status))
}

fn write_cache(path: &Path, k: &Kernel) -> Result<(), KernelError> {
    let io = |message: String| KernelError::Io {
        path: path.display().to_string(),
        message,
    };
    let key = cache_key(&k.params);
    let file = CacheFile {
        version: 1,
        solver: SOLVER_TAG.into(),
        checksum: checksum(&key, &k.x_m, &k.pressure_per_pa),
        key,
        params: k.params,
        x_m: k.x_m.clone(),
        pressure_per_pa: k.pressure_per_pa.clone(),
    };
    let text = ron::ser::to_string_pretty(&file, ron::ser::PrettyConfig::default())
        .map_err(|e| io(e.to_string()))?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| io(e.to_string()))?;
    }
    let tmp = path.with_extension(format!("ron.tmp{}", std::process::id()));
    std::fs::write(&tmp, text).map_err(|e| io(e.to_string()))?;
    std::fs::rename(&tmp, path).map_err(|e| io(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hole(a: f64, h: f64) -> KernelParams {
        KernelParams {
            tissue: Material::new(20e3, 0.45),
            lumen_radius_m: a,
            wall_thickness_m: 0.0,
            wall: Material::new(20e3, 0.45),
            centre_depth_m: h,
            refine: 0,
            backing_depth_m: None,
        }
    }

    #[test]
    fn a_small_deep_hole_matches_the_analytic_kernel_and_has_zero_net_force() {
        let p = hole(0.0005, 0.005);
        let k = compute(&p).unwrap();
        let a0 = analytic_per_pa(0.0, 0.0005, 0.005);
        let k0 = k.at(0.0);
        assert!((k0 - a0).abs() < 0.05 * a0, "fem {k0} analytic {a0}");
        // Sign change beyond |x| = h and the out-of-phase minimum near |x| = √3 h.
        assert!(k.at(0.0035) > 0.0 && k.at(0.007) < 0.0);
        let m = analytic_per_pa(0.005 * 3f64.sqrt(), 0.0005, 0.005);
        let km = k.at(0.005 * 3f64.sqrt());
        // Within 15%: the rigid bottom 8 depths down and the free sides pull the far lobe in.
        assert!((km - m).abs() < 0.15 * m.abs(), "fem {km} analytic {m}");
        let net = k.net_force_m() / k.total_magnitude_m();
        assert!(net.abs() < 0.02, "net/total {net} (fem {k0} analytic {a0})");
    }

    #[test]
    fn a_stiff_wall_carries_the_pressure() {
        let mut p = hole(0.0015, 0.005);
        let bare = compute(&p).unwrap().at(0.0);
        p.wall_thickness_m = 0.001;
        p.wall = Material::new(1.5e6, 0.49);
        let walled = compute(&p).unwrap().at(0.0);
        assert!(
            walled > 0.0 && walled < 0.25 * bare,
            "walled {walled} bare {bare}"
        );
    }

    #[test]
    fn a_backing_lets_the_surface_carry_the_tubes_force() {
        let (a, h) = (0.0005, 0.005);
        let mut p = hole(a, h);
        let free = compute(&p).unwrap();
        p.backing_depth_m = Some(0.010);
        let backed = compute(&p).unwrap();
        // Hanging from the surface (the half-space stand-in) the surface carries no net
        // force; on a backing the surface and the backing take equal and opposite net
        // forces, a part of the lumen's vertical thrust 2a (per Pa, per unit length): here
        // about 15 %.
        assert!(free.net_force_m().abs() < 0.02 * free.total_magnitude_m());
        let net = backed.net_force_m();
        assert!(net > 0.1 * 2.0 * a && net < 2.0 * a, "net {net}");
        assert!(net > 0.5 * backed.total_magnitude_m(), "net {net}");
        // And nowhere does the surface pull: no out-of-phase flank this close to the table.
        assert!(
            backed
                .pressure_per_pa
                .iter()
                .all(|&v| v > -1e-4 * backed.at(0.0))
        );
        assert!(backed.at(0.0) > free.at(0.0));
    }

    #[test]
    fn a_backing_too_close_is_refused_and_none_keeps_the_cache_key() {
        let mut p = hole(0.0015, 0.005);
        // The hole's mesh (with its ring of 0.25 radii) needs 1.2 meshed radii below it.
        p.backing_depth_m = Some(0.005 + 1.1 * 1.25 * 0.0015);
        assert!(matches!(compute(&p), Err(KernelError::BadParams)));
        p.backing_depth_m = Some(0.005 + 1.3 * 1.25 * 0.0015);
        assert!(compute(&p).is_ok());
        // Kernels without a backing keep the key they had before the option existed.
        let text = ron::to_string(&hole(0.0015, 0.005)).unwrap();
        assert!(!text.contains("backing"), "{text}");
        // The scene's spec puts the backing below the tube and flattens the wall on request.
        let spec = FemKernelSpec {
            tissue: Material::new(50e3, 0.49),
            wall: Material::new(400e3, 0.49),
            refine: 0,
            backing_gap_m: Some(0.001),
            wall_flattened: true,
        };
        let k = spec.params(0.0013, 0.0003, 0.0034);
        assert!((k.lumen_radius_m - 0.0016).abs() < 1e-15);
        assert_eq!(k.wall_thickness_m, 0.0);
        assert!((k.backing_depth_m.unwrap() - 0.0060).abs() < 1e-12);
    }

    #[test]
    fn the_cache_is_used_and_corrupt_or_stale_files_are_recomputed() {
        let dir = std::env::temp_dir().join(format!("pulsetrack-kernel-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let p = hole(0.0005, 0.004);
        let (k1, s1) = load_or_compute(&p, &dir).unwrap();
        assert_eq!(s1, CacheStatus::Computed);
        let (k2, s2) = load_or_compute(&p, &dir).unwrap();
        assert_eq!(s2, CacheStatus::Hit);
        assert_eq!(k1, k2);
        assert_eq!(cache_key(&p), cache_key(&hole(0.0005, 0.004)));
        assert_ne!(cache_key(&p), cache_key(&hole(0.0005, 0.0041)));

        // Corrupt one sample: the checksum catches it.
        let path = cache_path(&dir, &p);
        let text = std::fs::read_to_string(&path).unwrap();
        let idx = text.find("pressure_per_pa").unwrap();
        let digit = text[idx..].find(|c: char| c.is_ascii_digit()).unwrap() + idx;
        let mut bytes = text.into_bytes();
        bytes[digit] = if bytes[digit] == b'7' { b'3' } else { b'7' };
        std::fs::write(&path, &bytes).unwrap();
        let (k3, s3) = load_or_compute(&p, &dir).unwrap();
        assert!(
            matches!(&s3, CacheStatus::Recomputed(r) if r.contains("checksum")),
            "{s3:?}"
        );
        assert_eq!(k3, k1);
        // Truncated file.
        std::fs::write(&path, "FemKernelCache(version: 1, solv").unwrap();
        assert!(matches!(
            load_or_compute(&p, &dir).unwrap().1,
            CacheStatus::Recomputed(_)
        ));
        // A file for other parameters placed under this key is stale.
        let other = hole(0.0006, 0.004);
        let (ko, _) = load_or_compute(&other, &dir).unwrap();
        std::fs::copy(cache_path(&dir, &other), &path).unwrap();
        let (k4, s4) = load_or_compute(&p, &dir).unwrap();
        assert!(matches!(s4, CacheStatus::Recomputed(_)), "{s4:?}");
        assert_eq!(k4, k1);
        assert_ne!(ko, k1);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
