//! Synthetic noise of the mesh-denoising literature (SPEC §2; the model of
//! the GNF reference code `bldeng/GuidedDenoising` `Noise.cpp`, used for the
//! NormalNet training data and for every `data/gd` pair).
//!
//! `σ = L · l_e` (`l_e` the mean unique-edge length of the clean mesh).
//! Gaussian: every vertex moves `t · d`, `t ~ N(0, σ²)`. Impulsive: `⌊p · #V⌋`
//! vertices chosen uniformly without replacement move that way, the rest stay
//! bit-identical. `d` is the clean vertex normal (normalised unweighted sum of
//! incident unit face normals; zero for isolated vertices, which then do not
//! move) or, on request, a uniformly random unit vector per moved vertex.
//!
//! Random numbers come from ChaCha8 seeded with `seed`, drawn in a fixed order
//! (chosen vertices, then all offsets `t`, then random directions), so one
//! seed gives the same bytes on every machine and thread count.

use crate::error::MeshError;
use crate::geometry::{face_normals, vertex_normals};
use crate::mesh::Mesh;
use crate::vec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, UnitSphere};

/// Direction of the displacement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseDirection {
    /// Along the clean vertex normal (the reference default).
    #[default]
    Normal,
    /// Along a uniformly random unit vector, independent per vertex.
    Random,
}

/// Noise parameters; `Default` is Gaussian noise of level 0.3 along the
/// normals with seed 0.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
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
}

impl Default for NoiseParams {
    fn default() -> Self {
        NoiseParams {
            level: 0.3,
            impulsive_fraction: None,
            direction: NoiseDirection::Normal,
            seed: 0,
        }
    }
}

/// What [`add_noise_with_info`] did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct NoiseInfo {
    /// `l_e` of the clean mesh
    pub mean_edge_length: f64,
    /// `σ = L · l_e`
    pub sigma: f64,
    /// number of displaced vertices
    pub displaced: usize,
}

/// Adds noise to a clean mesh (connectivity unchanged).
///
/// # Errors
/// [`MeshError::InvalidParameter`] for a negative or non-finite level, a
/// fraction outside `[0, 1]`, or a clean mesh of zero mean edge length
/// (every face collapsed to a point: `σ = L·l_e` would be 0 and nothing
/// would move).
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
    if !(params.level.is_finite() && params.level >= 0.0) {
        return Err(MeshError::InvalidParameter {
            name: "level",
            message: format!("must be a finite number >= 0, got {}", params.level),
        });
    }
    if let Some(p) = params.impulsive_fraction
        && !(0.0..=1.0).contains(&p)
    {
        return Err(MeshError::InvalidParameter {
            name: "impulsive_fraction",
            message: format!("must be in [0, 1], got {p}"),
        });
    }
    let n = clean.num_vertices();
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
    let normal = Normal::new(0.0, sigma).map_err(|e| MeshError::InvalidParameter {
        name: "level",
        message: e.to_string(),
    })?;
    let t: Vec<f64> = chosen.iter().map(|_| normal.sample(&mut rng)).collect();
    let dirs: Vec<[f64; 3]> = match params.direction {
        NoiseDirection::Normal => {
            let vn = vertex_normals(clean, &face_normals(clean));
            chosen.iter().map(|&i| vn[i]).collect()
        }
        NoiseDirection::Random => chosen.iter().map(|_| UnitSphere.sample(&mut rng)).collect(),
    };
    let mut positions = clean.positions.clone();
    for ((&i, &ti), &d) in chosen.iter().zip(&t).zip(&dirs) {
        positions[i] = vec3::add(positions[i], vec3::scale(d, ti));
    }
    // Displacements are finite (σ finite, |d| ≤ 1) unless the mesh is near
    // the f64 range: then say so instead of returning NaN.
    let noisy = Mesh::new(positions, clean.faces.clone())?;
    Ok((
        noisy,
        NoiseInfo {
            mean_edge_length: le,
            sigma,
            displaced: chosen.len(),
        },
    ))
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
}
