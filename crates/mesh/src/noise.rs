//! Synthetic noise of the mesh-denoising literature (SPEC §2; the model of
//! the GNF reference code `bldeng/GuidedDenoising` `Noise.cpp`, used for the
//! NormalNet training data and for every `data/gd` pair), and noise that
//! looks like real scanners (issue 34).
//!
//! `σ = L · l_e` (`l_e` the mean unique-edge length of the clean mesh).
//! Gaussian: every vertex moves `t · d`, `t ~ N(0, σ²)`. Impulsive: `⌊p · #V⌋`
//! vertices chosen uniformly without replacement move that way, the rest stay
//! bit-identical. `d` is the clean vertex normal (normalised unweighted sum of
//! incident unit face normals; zero for isolated vertices, which then do not
//! move) or, on request, a uniformly random unit vector per moved vertex.
//!
//! Scanner-like noise, each a field of [`NoiseParams`] (combinable):
//! - **along a viewing direction** ([`NoiseDirection::View`]): every moved
//!   vertex moves along one unit vector `v` (given, or drawn uniformly from
//!   the seed), as a range sensor looking along `v` errs in depth;
//! - **depth-dependent σ** (`depth_gain` k, with the view direction):
//!   `σ_i = L·l_e·(1 + k·δ_i)`, `δ_i = (v·p_i − min_j v·p_j) / (max_j v·p_j −
//!   min_j v·p_j)` the vertex's relative depth along `v`, 0 at the point
//!   nearest the viewer and 1 at the farthest;
//! - **spatially correlated, low-frequency** (`correlation_length` λ):
//!   instead of independent draws, `t_i = σ_i·f(p_i)` with `f` a stationary
//!   random field of unit variance and covariance `exp(−|p − q|² / (2ℓ²))`,
//!   `ℓ = λ·l_e`, built from [`FIELD_FEATURES`] random Fourier features
//!   (Rahimi & Recht 2007, "Random features for large-scale kernel machines"):
//!   `f(p) = √(2/K) Σ_k cos(ω_k·(p − c) + φ_k)`, `ω_k ~ N(0, I/ℓ²)`,
//!   `φ_k ~ U[0, 2π)`, `c` the bounding-box centre. With random directions
//!   the displacement is three such fields (x, y, z), each of variance σ²/3,
//!   so that its mean square is σ² as for independent random directions;
//! - **mixtures** ([`add_noise_mixture`]): several components, each with its
//!   own parameters and seed, computed on the clean mesh (its normals, `l_e`
//!   and depths) and added in order, e.g. Gaussian everywhere plus impulsive
//!   outliers.
//!
//! Random numbers come from ChaCha8 seeded with `seed`, drawn in a fixed order
//! (chosen vertices, then a seeded view direction, then all offsets `t` or
//! the field's features, then random directions), so one seed gives the same
//! bytes on every machine and thread count; parameters of the classic noise
//! (no view direction, no correlation) draw exactly what they always drew.

use crate::error::MeshError;
use crate::geometry::{face_normals, vertex_normals};
use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal, UnitSphere};

/// Number of random Fourier features `K` of a correlated noise field.
pub const FIELD_FEATURES: usize = 64;

/// Direction of the displacement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseDirection {
    /// Along the clean vertex normal (the reference default).
    #[default]
    Normal,
    /// Along a uniformly random unit vector, independent per vertex.
    Random,
    /// Along one viewing direction for every vertex
    /// ([`NoiseParams::view_direction`], or drawn from the seed).
    View,
}

/// Noise parameters; `Default` is Gaussian noise of level 0.3 along the
/// normals with seed 0. In TOML/JSON (serde) every field is optional, e.g.
/// `{ level = 0.5, impulsive_fraction = 0.3, seed = 4 }`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseParams {
    /// `L`: standard deviation in units of the mean edge length (`σ = L·l_e`).
    pub level: f64,
    /// `p`: impulsive noise moves only `⌊p·#V⌋` vertices; `None` moves all
    /// (Gaussian noise).
    pub impulsive_fraction: Option<f64>,
    /// Displacement direction (`d`).
    pub direction: NoiseDirection,
    /// Seed of the random number generator.
    pub seed: u64,
    /// `v` of [`NoiseDirection::View`] (any non-zero length; normalised);
    /// `None` draws it uniformly from the seed. Only with that direction.
    pub view_direction: Option<Vec3>,
    /// `k`: σ grows with the relative depth δ along the view direction,
    /// `σ_i = L·l_e·(1 + k·δ_i)` (δ from 0 nearest to 1 farthest); default
    /// 0 (constant σ). Only with [`NoiseDirection::View`].
    pub depth_gain: f64,
    /// `λ`: correlation length of spatially correlated noise in units of
    /// `l_e` (`ℓ = λ·l_e`); `None`: independent offsets per vertex.
    pub correlation_length: Option<f64>,
}

impl Default for NoiseParams {
    fn default() -> Self {
        NoiseParams {
            level: 0.3,
            impulsive_fraction: None,
            direction: NoiseDirection::Normal,
            seed: 0,
            view_direction: None,
            depth_gain: 0.0,
            correlation_length: None,
        }
    }
}

impl NoiseParams {
    /// Reads a one-line description `key=value,key=value,...` laid over
    /// `base` (the keys not given keep `base`'s values): `level=L`,
    /// `impulsive=FRACTION`, `direction=normal|random|view`, `view=X:Y:Z`
    /// (implies `direction=view`), `depth_gain=K`, `correlation=LAMBDA`,
    /// `seed=N`. Used for mixture components on the command line.
    ///
    /// # Errors
    /// [`MeshError::InvalidParameter`] naming the unknown key or bad value.
    pub fn parse_spec(spec: &str, base: &NoiseParams) -> Result<NoiseParams, MeshError> {
        let bad = |message: String| MeshError::InvalidParameter {
            name: "noise spec",
            message,
        };
        let number = |key: &str, v: &str| -> Result<f64, MeshError> {
            v.trim()
                .parse::<f64>()
                .map_err(|_| bad(format!("{spec:?}: {key}={v} is not a number")))
        };
        let mut p = *base;
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| bad(format!("{spec:?}: expected key=value, got {item:?}")))?;
            match key.trim() {
                "level" => p.level = number(key, value)?,
                "impulsive" => p.impulsive_fraction = Some(number(key, value)?),
                "direction" => {
                    p.direction = match value.trim() {
                        "normal" => NoiseDirection::Normal,
                        "random" => NoiseDirection::Random,
                        "view" => NoiseDirection::View,
                        other => {
                            return Err(bad(format!(
                                "{spec:?}: direction {other:?} (expected normal, random or view)"
                            )));
                        }
                    }
                }
                "view" => {
                    let c: Vec<f64> = value
                        .split(':')
                        .map(|c| number(key, c))
                        .collect::<Result<_, _>>()?;
                    let [x, y, z] = c[..] else {
                        return Err(bad(format!("{spec:?}: view=X:Y:Z, got {value:?}")));
                    };
                    p.view_direction = Some([x, y, z]);
                    p.direction = NoiseDirection::View;
                }
                "depth_gain" => p.depth_gain = number(key, value)?,
                "correlation" => p.correlation_length = Some(number(key, value)?),
                "seed" => {
                    p.seed = value
                        .trim()
                        .parse()
                        .map_err(|_| bad(format!("{spec:?}: seed={value} is not a whole number")))?
                }
                other => {
                    return Err(bad(format!(
                        "{spec:?}: unknown key {other:?} (known: level, impulsive, direction, \
                         view, depth_gain, correlation, seed)"
                    )));
                }
            }
        }
        Ok(p)
    }

    /// Checks the ranges and combinations of the fields.
    ///
    /// # Errors
    /// [`MeshError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<(), MeshError> {
        let bad = |name: &'static str, message: String| {
            Err(MeshError::InvalidParameter { name, message })
        };
        if !(self.level.is_finite() && self.level >= 0.0) {
            return bad(
                "level",
                format!("must be a finite number >= 0, got {}", self.level),
            );
        }
        if let Some(p) = self.impulsive_fraction
            && !(0.0..=1.0).contains(&p)
        {
            return bad("impulsive_fraction", format!("must be in [0, 1], got {p}"));
        }
        if let Some(v) = self.view_direction {
            if self.direction != NoiseDirection::View {
                return bad("view_direction", "needs direction = view".into());
            }
            let n = vec3::norm(v);
            if !(n.is_finite() && n > 0.0) {
                return bad(
                    "view_direction",
                    format!("must be a finite non-zero vector, got {v:?}"),
                );
            }
        }
        if !(self.depth_gain.is_finite() && self.depth_gain >= 0.0) {
            return bad(
                "depth_gain",
                format!("must be a finite number >= 0, got {}", self.depth_gain),
            );
        }
        if self.depth_gain != 0.0 && self.direction != NoiseDirection::View {
            return bad(
                "depth_gain",
                "depth is measured along the view direction: needs direction = view".into(),
            );
        }
        if let Some(l) = self.correlation_length
            && !(l.is_finite() && l > 0.0)
        {
            return bad(
                "correlation_length",
                format!("must be a finite number > 0, got {l}"),
            );
        }
        Ok(())
    }
}

/// What [`add_noise_with_info`] did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct NoiseInfo {
    /// `l_e` of the clean mesh
    pub mean_edge_length: f64,
    /// `σ = L · l_e` (at depth 0 when σ depends on depth)
    pub sigma: f64,
    /// number of displaced vertices
    pub displaced: usize,
    /// the unit view direction `v` used ([`NoiseDirection::View`] only)
    pub view_direction: Option<Vec3>,
}

/// Adds noise to a clean mesh (connectivity unchanged).
///
/// # Errors
/// [`MeshError::InvalidParameter`] for parameters [`NoiseParams::validate`]
/// refuses, or a clean mesh of zero mean edge length (every face collapsed
/// to a point: `σ = L·l_e` would be 0 and nothing would move).
pub fn add_noise(clean: &Mesh, params: &NoiseParams) -> Result<Mesh, MeshError> {
    add_noise_with_info(clean, params).map(|(m, _)| m)
}

/// [`add_noise`], also returning `σ`, `l_e` and the number of moved vertices.
///
/// # Errors
/// As [`add_noise`].
pub fn add_noise_with_info(
    clean: &Mesh,
    params: &NoiseParams,
) -> Result<(Mesh, NoiseInfo), MeshError> {
    let (noisy, mut info) = add_noise_mixture(clean, std::slice::from_ref(params))?;
    Ok((noisy, info.remove(0)))
}

/// A mixture: the displacements of every component, each computed on the
/// clean mesh with its own parameters and seed, added in order (one
/// [`NoiseInfo`] per component; `displaced` counts that component's moves).
/// One component gives exactly [`add_noise`]'s bytes.
///
/// # Errors
/// As [`add_noise`], for any component (checked before anything moves), and
/// [`MeshError::InvalidParameter`] for an empty list.
pub fn add_noise_mixture(
    clean: &Mesh,
    components: &[NoiseParams],
) -> Result<(Mesh, Vec<NoiseInfo>), MeshError> {
    if components.is_empty() {
        return Err(MeshError::InvalidParameter {
            name: "noise components",
            message: "a mixture needs at least one component".into(),
        });
    }
    for c in components {
        c.validate()?;
    }
    // l_e from the sorted unique edges (no full Topology needed).
    let le = crate::metrics::unique_edge_mean_length(clean);
    if le.is_nan() || le <= 0.0 {
        return Err(MeshError::InvalidParameter {
            name: "clean mesh",
            message: format!(
                "mean edge length l_e is {le} (the vertices of every face coincide): \
                 noise of sigma = L * l_e cannot move it"
            ),
        });
    }
    let needs_normals = components
        .iter()
        .any(|c| c.direction == NoiseDirection::Normal);
    let vn = if needs_normals {
        vertex_normals(clean, &face_normals(clean))
    } else {
        Vec::new()
    };
    let mut positions = clean.positions.clone();
    let mut infos = Vec::with_capacity(components.len());
    for params in components {
        let (moves, info) = displacements(clean, params, le, &vn)?;
        for (i, d) in moves {
            positions[i] = vec3::add(positions[i], d);
        }
        infos.push(info);
    }
    // Displacements are finite (σ finite, |d| ≤ 1) unless the mesh is near
    // the f64 range: then say so instead of returning NaN.
    let noisy = Mesh::new(positions, clean.faces.clone())?;
    Ok((noisy, infos))
}

/// The moves `(vertex, displacement)` of one noise component on the clean
/// mesh (`le` its mean edge length, `vn` its vertex normals when the
/// component goes along them).
fn displacements(
    clean: &Mesh,
    params: &NoiseParams,
    le: f64,
    vn: &[Vec3],
) -> Result<(Vec<(usize, Vec3)>, NoiseInfo), MeshError> {
    let n = clean.num_vertices();
    let sigma = params.level * le;
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let chosen: Vec<usize> = match params.impulsive_fraction {
        None => (0..n).collect(),
        Some(p) => {
            let k = ((p * n as f64).floor() as usize).min(n);
            let mut idx = rand::seq::index::sample(&mut rng, n, k).into_vec();
            idx.sort_unstable();
            idx
        }
    };
    let view = (params.direction == NoiseDirection::View).then(|| match params.view_direction {
        Some(v) => vec3::normalize_or_zero(v),
        None => UnitSphere.sample(&mut rng),
    });
    // σ_i of each chosen vertex (σ unless it grows with depth)
    let sigma_i: Vec<f64> = match view {
        Some(v) if params.depth_gain != 0.0 => {
            let depth: Vec<f64> = clean.positions.iter().map(|&p| vec3::dot(p, v)).collect();
            let near = depth.iter().copied().fold(f64::INFINITY, f64::min);
            let far = depth.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let range = far - near;
            chosen
                .iter()
                .map(|&i| {
                    let delta = if range > 0.0 {
                        (depth[i] - near) / range
                    } else {
                        0.0
                    };
                    sigma * (1.0 + params.depth_gain * delta)
                })
                .collect()
        }
        _ => vec![sigma; chosen.len()],
    };
    let moves: Vec<(usize, Vec3)> = match params.correlation_length {
        None => {
            let t: Vec<f64> = if view.is_none() {
                // the classic draws, unchanged
                let normal = Normal::new(0.0, sigma).map_err(|e| MeshError::InvalidParameter {
                    name: "level",
                    message: e.to_string(),
                })?;
                chosen.iter().map(|_| normal.sample(&mut rng)).collect()
            } else {
                sigma_i
                    .iter()
                    .map(|&s| {
                        let z: f64 = StandardNormal.sample(&mut rng);
                        s * z
                    })
                    .collect()
            };
            let dirs: Vec<Vec3> = match (params.direction, view) {
                (NoiseDirection::Normal, _) => chosen.iter().map(|&i| vn[i]).collect(),
                (NoiseDirection::Random, _) => {
                    chosen.iter().map(|_| UnitSphere.sample(&mut rng)).collect()
                }
                (NoiseDirection::View, v) => vec![v.unwrap_or_default(); chosen.len()],
            };
            chosen
                .iter()
                .zip(&t)
                .zip(&dirs)
                .map(|((&i, &ti), &d)| (i, vec3::scale(d, ti)))
                .collect()
        }
        Some(lambda) => {
            let ell = lambda * le;
            let (lo, hi) = clean.bounding_box();
            let centre = vec3::scale(vec3::add(lo, hi), 0.5);
            let fields = if params.direction == NoiseDirection::Random {
                3
            } else {
                1
            };
            let fields: Vec<SmoothField> = (0..fields)
                .map(|_| SmoothField::draw(ell, &mut rng))
                .collect();
            chosen
                .iter()
                .zip(&sigma_i)
                .map(|(&i, &s)| {
                    let p = vec3::sub(clean.positions[i], centre);
                    let d = match params.direction {
                        NoiseDirection::Normal => vec3::scale(vn[i], s * fields[0].at(p)),
                        NoiseDirection::View => {
                            vec3::scale(view.unwrap_or_default(), s * fields[0].at(p))
                        }
                        NoiseDirection::Random => {
                            let a = s / 3f64.sqrt();
                            [
                                fields[0].at(p) * a,
                                fields[1].at(p) * a,
                                fields[2].at(p) * a,
                            ]
                        }
                    };
                    (i, d)
                })
                .collect()
        }
    };
    Ok((
        moves,
        NoiseInfo {
            mean_edge_length: le,
            sigma,
            displaced: chosen.len(),
            view_direction: view,
        },
    ))
}

/// A stationary random field of unit variance with Gaussian covariance of
/// length `ℓ`, as [`FIELD_FEATURES`] random Fourier features (module doc).
struct SmoothField {
    /// `ω_k` (one per feature)
    frequencies: Vec<Vec3>,
    /// `φ_k`
    phases: Vec<f64>,
}

impl SmoothField {
    /// Draws the features: all `ω_k` (three standard normals each, over ℓ),
    /// then all `φ_k`.
    fn draw(ell: f64, rng: &mut ChaCha8Rng) -> SmoothField {
        let frequencies = (0..FIELD_FEATURES)
            .map(|_| {
                let g: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(rng));
                vec3::scale(g, 1.0 / ell)
            })
            .collect();
        let phases = (0..FIELD_FEATURES)
            .map(|_| rng.random::<f64>() * std::f64::consts::TAU)
            .collect();
        SmoothField {
            frequencies,
            phases,
        }
    }

    /// `f(p) = √(2/K) Σ_k cos(ω_k·p + φ_k)`.
    fn at(&self, p: Vec3) -> f64 {
        let sum: f64 = self
            .frequencies
            .iter()
            .zip(&self.phases)
            .map(|(&w, &phi)| (vec3::dot(w, p) + phi).cos())
            .sum();
        sum * (2.0 / FIELD_FEATURES as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed, subdivided octahedron-like grid sphere with `n`² quads per side.
    pub(crate) fn sphere(n: usize) -> Mesh {
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        // Cube surface grid, projected to the sphere.
        let mut index = std::collections::HashMap::new();
        let mut vid = |p: [i64; 3], positions: &mut Vec<[f64; 3]>| -> u32 {
            *index.entry(p).or_insert_with(|| {
                let q = [p[0] as f64, p[1] as f64, p[2] as f64];
                let l = vec3::norm(q);
                positions.push(vec3::scale(q, 1.0 / l));
                (positions.len() - 1) as u32
            })
        };
        let h = n as i64;
        for axis in 0..3 {
            for sign in [-1i64, 1] {
                for i in 0..n as i64 {
                    for j in 0..n as i64 {
                        let pt = |a: i64, b: i64| {
                            let mut p = [0i64; 3];
                            p[axis] = sign * h;
                            p[(axis + 1) % 3] = 2 * a - h;
                            p[(axis + 2) % 3] = 2 * b - h;
                            p
                        };
                        let c = [pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1)];
                        let v: Vec<u32> = c.iter().map(|&p| vid(p, &mut positions)).collect();
                        if sign > 0 {
                            faces.push([v[0], v[1], v[2]]);
                            faces.push([v[0], v[2], v[3]]);
                        } else {
                            faces.push([v[0], v[2], v[1]]);
                            faces.push([v[0], v[3], v[2]]);
                        }
                    }
                }
            }
        }
        Mesh::new(positions, faces).unwrap()
    }

    #[test]
    fn gaussian_statistics_direction_and_reproducibility() {
        let m = sphere(92); // 6·92² quads: 50 786 vertices
        assert!(m.num_vertices() >= 50_000, "{}", m.num_vertices());
        let params = NoiseParams {
            level: 0.3,
            seed: 11,
            ..NoiseParams::default()
        };
        let (noisy, info) = add_noise_with_info(&m, &params).unwrap();
        assert_eq!(info.displaced, m.num_vertices());
        let vn = vertex_normals(&m, &face_normals(&m));
        let mut s2 = 0.0;
        for ((a, b), n) in m.positions.iter().zip(&noisy.positions).zip(&vn) {
            let d = vec3::sub(*b, *a);
            let t = vec3::dot(d, *n);
            // Parallel to the clean normal: the remainder is rounding only.
            assert!(vec3::norm(vec3::sub(d, vec3::scale(*n, t))) <= 1e-12 * (1.0 + t.abs()));
            s2 += t * t;
        }
        let std = (s2 / m.num_vertices() as f64).sqrt();
        assert!(
            (std / info.sigma - 1.0).abs() < 0.02,
            "std {std} sigma {}",
            info.sigma
        );
        assert!((info.sigma - 0.3 * info.mean_edge_length).abs() < 1e-15);
        let again = add_noise(&m, &params).unwrap();
        assert_eq!(again, noisy, "same seed, same bytes");
        let other = add_noise(&m, &NoiseParams { seed: 12, ..params }).unwrap();
        assert_ne!(other, noisy);
        assert_eq!(noisy.faces, m.faces);
    }

    #[test]
    fn impulsive_moves_exactly_floor_pn_vertices() {
        let m = sphere(10);
        let n = m.num_vertices();
        for p in [0.0, 0.1, 0.37, 1.0] {
            let params = NoiseParams {
                level: 0.5,
                impulsive_fraction: Some(p),
                seed: 5,
                ..NoiseParams::default()
            };
            let (noisy, info) = add_noise_with_info(&m, &params).unwrap();
            let moved = m
                .positions
                .iter()
                .zip(&noisy.positions)
                .filter(|(a, b)| a != b)
                .count();
            let k = (p * n as f64).floor() as usize;
            assert_eq!(info.displaced, k);
            assert_eq!(moved, k, "p {p}"); // t = 0 exactly has probability 0
        }
    }

    #[test]
    fn random_direction_and_bad_parameters() {
        let m = sphere(6);
        let params = NoiseParams {
            direction: NoiseDirection::Random,
            seed: 1,
            ..NoiseParams::default()
        };
        let noisy = add_noise(&m, &params).unwrap();
        let vn = vertex_normals(&m, &face_normals(&m));
        // Random directions are (almost surely) not all along the normals.
        let off = m
            .positions
            .iter()
            .zip(&noisy.positions)
            .zip(&vn)
            .filter(|((a, b), n)| {
                let d = vec3::sub(**b, **a);
                vec3::norm(vec3::cross(d, **n)) > 1e-6 * vec3::norm(d)
            });
        assert!(off.count() > m.num_vertices() / 2);
        for (level, frac, name) in [
            (-1.0, None, "level"),
            (f64::NAN, None, "level"),
            (0.3, Some(1.5), "impulsive_fraction"),
        ] {
            let e = add_noise(
                &m,
                &NoiseParams {
                    level,
                    impulsive_fraction: frac,
                    ..params
                },
            )
            .unwrap_err();
            assert!(e.to_string().contains(name), "{e}");
        }
    }

    /// Audit: a mesh whose vertices all coincide got "81 of 81 vertices
    /// moved" with sigma 0; it is refused.
    #[test]
    fn a_mesh_of_zero_edge_length_is_refused() {
        let m = Mesh::height_grid(3, |_, _| 0.0);
        let point = m.with_positions(vec![[1.0, 2.0, 3.0]; m.num_vertices()]);
        let e = add_noise(&point, &NoiseParams::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("clean mesh") && e.contains("mean edge length"),
            "{e}"
        );
        assert!(add_noise(&m, &NoiseParams::default()).is_ok());
    }
    /// Offsets `t_i = d_i · n_i` along the clean vertex normals.
    fn normal_offsets(clean: &Mesh, noisy: &Mesh) -> Vec<f64> {
        let vn = vertex_normals(clean, &face_normals(clean));
        clean
            .positions
            .iter()
            .zip(&noisy.positions)
            .zip(&vn)
            .map(|((a, b), n)| vec3::dot(vec3::sub(*b, *a), *n))
            .collect()
    }

    fn mean_and_std(t: &[f64]) -> (f64, f64) {
        let mean = t.iter().sum::<f64>() / t.len() as f64;
        let ms = t.iter().map(|x| x * x).sum::<f64>() / t.len() as f64;
        (mean, ms.sqrt())
    }

    /// Pearson correlation of the offsets at the two ends of every edge.
    fn neighbour_correlation(mesh: &Mesh, t: &[f64]) -> f64 {
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        let (mean, _) = mean_and_std(t);
        for f in &mesh.faces {
            for k in 0..3 {
                let (a, b) = (t[f[k] as usize] - mean, t[f[(k + 1) % 3] as usize] - mean);
                sab += a * b;
                saa += a * a;
                sbb += b * b;
            }
        }
        sab / (saa * sbb).sqrt()
    }

    #[test]
    fn view_noise_moves_along_one_direction_with_sigma_growing_with_depth() {
        let m = sphere(40);
        let k = 3.0;
        let params = NoiseParams {
            level: 0.3,
            direction: NoiseDirection::View,
            view_direction: Some([0.0, 0.0, 2.0]),
            depth_gain: k,
            seed: 21,
            ..NoiseParams::default()
        };
        let (noisy, info) = add_noise_with_info(&m, &params).unwrap();
        assert_eq!(info.view_direction, Some([0.0, 0.0, 1.0]));
        assert_eq!(info.displaced, m.num_vertices());
        // depth along +z: from z = -1 (nearest) to z = +1 (farthest)
        let mut near = Vec::new();
        let mut far = Vec::new();
        let mut normalised = Vec::new();
        for (a, b) in m.positions.iter().zip(&noisy.positions) {
            let d = vec3::sub(*b, *a);
            assert!(d[0] == 0.0 && d[1] == 0.0, "moved off the view axis: {d:?}");
            let delta = (a[2] + 1.0) / 2.0;
            normalised.push(d[2] / (1.0 + k * delta));
            if delta < 0.2 {
                near.push(d[2]);
            } else if delta > 0.8 {
                far.push(d[2]);
            }
        }
        let (mean, std) = mean_and_std(&normalised);
        assert!(mean.abs() < 0.05 * info.sigma, "mean {mean}");
        assert!(
            (std / info.sigma - 1.0).abs() < 0.05,
            "std {std} sigma {}",
            info.sigma
        );
        let (_, s_near) = mean_and_std(&near);
        let (_, s_far) = mean_and_std(&far);
        // expected σ at δ ≈ 0.1 and ≈ 0.9: 1.3σ and 3.7σ
        assert!(
            s_near < 1.5 * info.sigma && s_far > 3.3 * info.sigma,
            "{s_near} {s_far}"
        );
        assert!(s_far / s_near > 2.3, "depth dependence {s_near} -> {s_far}");
        // a seeded direction: unit, reproducible, every move along it
        let seeded = NoiseParams {
            view_direction: None,
            depth_gain: 0.0,
            ..params
        };
        let (a, ia) = add_noise_with_info(&m, &seeded).unwrap();
        let (b, ib) = add_noise_with_info(&m, &seeded).unwrap();
        assert_eq!(a, b, "same seed, same bytes");
        let v = ia.view_direction.unwrap();
        assert_eq!(ib.view_direction, Some(v));
        assert!((vec3::norm(v) - 1.0).abs() < 1e-12);
        for (p, q) in m.positions.iter().zip(&a.positions) {
            let d = vec3::sub(*q, *p);
            assert!(vec3::norm(vec3::cross(d, v)) <= 1e-9 * (1e-12 + vec3::norm(d)));
        }
        let other = add_noise(&m, &NoiseParams { seed: 22, ..seeded }).unwrap();
        assert_ne!(other, a);
    }

    #[test]
    fn correlated_noise_has_the_target_std_and_correlated_neighbours() {
        let m = sphere(60);
        let params = NoiseParams {
            level: 0.4,
            correlation_length: Some(6.0),
            seed: 3,
            ..NoiseParams::default()
        };
        let (noisy, info) = add_noise_with_info(&m, &params).unwrap();
        let t = normal_offsets(&m, &noisy);
        let (mean, std) = mean_and_std(&t);
        assert!(
            mean.abs() < 0.15 * info.sigma,
            "mean {mean} sigma {}",
            info.sigma
        );
        assert!(
            (std / info.sigma - 1.0).abs() < 0.15,
            "std {std} sigma {}",
            info.sigma
        );
        let rho = neighbour_correlation(&m, &t);
        // Gaussian covariance at one edge (ℓ = 6 l_e): exp(-1/72) ≈ 0.986
        assert!(rho > 0.9, "neighbour correlation {rho}");
        // the classic noise, for comparison: independent neighbours
        let white = add_noise(
            &m,
            &NoiseParams {
                correlation_length: None,
                ..params
            },
        )
        .unwrap();
        let rho_white = neighbour_correlation(&m, &normal_offsets(&m, &white));
        assert!(
            rho_white.abs() < 0.05,
            "white noise correlation {rho_white}"
        );
        assert_eq!(
            add_noise(&m, &params).unwrap(),
            noisy,
            "same seed, same bytes"
        );
        assert_ne!(
            add_noise(&m, &NoiseParams { seed: 4, ..params }).unwrap(),
            noisy
        );
        // random directions: three fields, mean square |d|² = σ²
        let random = NoiseParams {
            direction: NoiseDirection::Random,
            ..params
        };
        let r = add_noise(&m, &random).unwrap();
        let d2: Vec<f64> = m
            .positions
            .iter()
            .zip(&r.positions)
            .map(|(a, b)| vec3::norm(vec3::sub(*b, *a)))
            .collect();
        let (_, rms) = mean_and_std(&d2);
        assert!(
            (rms / info.sigma - 1.0).abs() < 0.15,
            "rms {rms} sigma {}",
            info.sigma
        );
    }

    #[test]
    fn a_mixture_adds_its_components_in_order() {
        let m = sphere(20);
        let n = m.num_vertices();
        let gaussian = NoiseParams {
            level: 0.2,
            seed: 1,
            ..NoiseParams::default()
        };
        let outliers = NoiseParams {
            level: 1.0,
            impulsive_fraction: Some(0.1),
            seed: 9,
            ..NoiseParams::default()
        };
        let (one, _) = add_noise_mixture(&m, &[gaussian]).unwrap();
        assert_eq!(
            one,
            add_noise(&m, &gaussian).unwrap(),
            "one component = add_noise"
        );
        let (mixed, infos) = add_noise_mixture(&m, &[gaussian, outliers]).unwrap();
        assert_eq!(infos.len(), 2);
        assert_eq!((infos[0].displaced, infos[1].displaced), (n, n / 10));
        // exactly the outliers differ from the Gaussian-only mesh, by the
        // outlier component's own displacement
        let alone = add_noise(&m, &outliers).unwrap();
        let mut differing = 0;
        for i in 0..n {
            let extra = vec3::sub(mixed.positions[i], one.positions[i]);
            let own = vec3::sub(alone.positions[i], m.positions[i]);
            if extra != [0.0; 3] {
                differing += 1;
            }
            assert!(vec3::norm(vec3::sub(extra, own)) <= 1e-12, "vertex {i}");
        }
        assert_eq!(differing, n / 10);
        assert_eq!(
            add_noise_mixture(&m, &[gaussian, outliers]).unwrap().0,
            mixed
        );
        assert!(add_noise_mixture(&m, &[]).is_err());
    }

    #[test]
    fn specs_parse_over_a_base_and_bad_combinations_name_the_field() {
        let base = NoiseParams {
            seed: 5,
            ..NoiseParams::default()
        };
        let p = NoiseParams::parse_spec("level=1.0, impulsive=0.1", &base).unwrap();
        assert_eq!(
            p,
            NoiseParams {
                level: 1.0,
                impulsive_fraction: Some(0.1),
                ..base
            }
        );
        let p =
            NoiseParams::parse_spec("view=0:0:1,depth_gain=2,correlation=8,seed=3", &base).unwrap();
        assert_eq!(p.direction, NoiseDirection::View);
        assert_eq!(p.view_direction, Some([0.0, 0.0, 1.0]));
        assert_eq!(
            (p.depth_gain, p.correlation_length, p.seed),
            (2.0, Some(8.0), 3)
        );
        for (spec, needle) in [
            ("levle=1", "levle"),
            ("level=x", "level=x"),
            ("direction=up", "up"),
            ("view=1:2", "view=X:Y:Z"),
            ("level", "key=value"),
        ] {
            let e = NoiseParams::parse_spec(spec, &base)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{spec}: {e}");
        }
        let m = sphere(4);
        for (params, field) in [
            (
                NoiseParams {
                    depth_gain: 1.0,
                    ..base
                },
                "depth_gain",
            ),
            (
                NoiseParams {
                    view_direction: Some([0.0, 0.0, 1.0]),
                    ..base
                },
                "view_direction",
            ),
            (
                NoiseParams {
                    direction: NoiseDirection::View,
                    view_direction: Some([0.0; 3]),
                    ..base
                },
                "view_direction",
            ),
            (
                NoiseParams {
                    correlation_length: Some(0.0),
                    ..base
                },
                "correlation_length",
            ),
        ] {
            let e = add_noise(&m, &params).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }
}
