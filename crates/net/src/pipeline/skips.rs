//! Which faces need the network in an iteration (the select stage). Three
//! skips, each optional, each keeping a face's filtered normal without
//! voxelizing it:
//! - **frozen** (`freeze_deg`): its output turned less than that between
//!   two iterations; it keeps that output for the rest of the run;
//! - **flat** (`flat_skip_deg`, from iteration 2 on): its 2-ring is flat;
//!   it takes the 2-ring's mean normal (frozen faces too);
//! - **reused** (`reuse_move`): the same network evaluated it before and no
//!   vertex around it has moved farther than that since; it keeps that
//!   output.

use normalnet_mesh::geometry::mean_edge_length;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, Topology};
use rayon::prelude::*;

use super::DenoiseParams;

/// The faces of one iteration that the network evaluates, and those that
/// reused an output.
#[derive(Clone, Debug, Default)]
pub struct Selection {
    /// faces to evaluate, ascending
    pub active: Vec<u32>,
    /// per face whether it reused an output (empty when reuse is off)
    pub reused: Vec<bool>,
}

impl Selection {
    /// Whether face `f` reused an output in this iteration.
    pub fn is_reused(&self, f: usize) -> bool {
        self.reused.get(f).copied().unwrap_or(false)
    }
}

/// The state of the skips over a run.
pub struct Skips<'m> {
    mesh: &'m Mesh,
    topology: &'m Topology,
    freeze_deg: f64,
    flat_skip_deg: f64,
    frozen: Vec<bool>,
    /// `reuse_move` on: the paths moved and the last outputs
    reuse: Option<Reuse>,
}

/// What the reuse skip remembers (48 MB per million faces, allocated only
/// when it is on).
struct Reuse {
    /// `reuse_move` in mesh units (× mean edge length)
    limit: f64,
    /// per vertex the length of the path it has moved so far
    path: Vec<f64>,
    /// `path` at the start of every iteration
    path_at: Vec<Vec<f64>>,
    /// per face the last output it got: (network, iteration, normal)
    last_output: Vec<Option<(usize, usize, Vec3)>>,
}

impl<'m> Skips<'m> {
    /// The skips `params` turn on, for a run on `mesh`.
    pub fn new(mesh: &'m Mesh, topology: &'m Topology, params: &DenoiseParams) -> Skips<'m> {
        let reuse = (params.reuse_move > 0.0).then(|| Reuse {
            limit: params.reuse_move * mean_edge_length(mesh, topology),
            path: vec![0.0; mesh.num_vertices()],
            path_at: Vec::new(),
            last_output: vec![None; mesh.num_faces()],
        });
        Skips {
            mesh,
            topology,
            freeze_deg: params.freeze_deg,
            flat_skip_deg: params.flat_skip_deg,
            frozen: vec![false; mesh.num_faces()],
            reuse,
        }
    }

    /// Whether the reuse skip is on (it needs the positions before each
    /// vertex update, [`Skips::moved`]).
    pub fn tracks_moves(&self) -> bool {
        self.reuse.is_some()
    }

    /// The faces network `i` (0-based) must evaluate in iteration `k` of
    /// `current`; the flat and reused faces' entries of `normals` (the
    /// previous iteration's filtered normals) are set here.
    pub fn select(
        &mut self,
        k: usize,
        i: usize,
        current: &Mesh,
        normals: &mut [Vec3],
    ) -> Selection {
        let n = normals.len();
        let flat = if self.flat_skip_deg > 0.0 && k > 1 {
            take_flat_means(current, self.topology, self.flat_skip_deg, normals)
        } else {
            vec![false; n]
        };
        if let Some(r) = self.reuse.as_mut() {
            r.path_at.push(r.path.clone());
        }
        let mut selection = Selection {
            active: Vec::with_capacity(n),
            reused: vec![false; if self.reuse.is_some() { n } else { 0 }],
        };
        for f in 0..n {
            if self.frozen[f] || flat[f] {
                continue;
            }
            match self.reused_output(f, i) {
                Some(normal) => {
                    normals[f] = normal;
                    selection.reused[f] = true;
                }
                None => selection.active.push(f as u32),
            }
        }
        selection
    }

    /// Face `f`'s earlier output of network `i`, if no vertex around it has
    /// moved farther than the limit since.
    fn reused_output(&self, f: usize, i: usize) -> Option<Vec3> {
        let r = self.reuse.as_ref()?;
        let (network, at, normal) = r.last_output[f]?;
        let unmoved = network == i
            && self.topology.face_neighbours.row(f).iter().all(|&g| {
                self.mesh.faces[g as usize]
                    .iter()
                    .all(|&v| r.path[v as usize] - r.path_at[at - 1][v as usize] < r.limit)
            });
        unmoved.then_some(normal)
    }

    /// Records the outputs network `i` gave the active faces in iteration
    /// `k`, and freezes those that turned less than `freeze_deg` since the
    /// previous iteration (`changes`: per face, degrees; `None` in the
    /// first iteration).
    pub fn record(
        &mut self,
        k: usize,
        i: usize,
        selection: &Selection,
        normals: &[Vec3],
        changes: Option<&[f64]>,
    ) {
        if let Some(r) = self.reuse.as_mut() {
            for &f in &selection.active {
                r.last_output[f as usize] = Some((i, k, normals[f as usize]));
            }
        }
        if let Some(changes) = changes
            && self.freeze_deg > 0.0
        {
            for &f in &selection.active {
                self.frozen[f as usize] = changes[f as usize] < self.freeze_deg;
            }
        }
    }

    /// Adds the vertex moves of one update (`before` → `after`) to the
    /// paths the reuse skip measures.
    pub fn moved(&mut self, before: &[Vec3], after: &[Vec3]) {
        if let Some(r) = self.reuse.as_mut() {
            for ((length, a), b) in r.path.iter_mut().zip(before).zip(after) {
                *length += vec3::norm(vec3::sub(*b, *a));
            }
        }
    }
}

/// The faces of `mesh` whose 2-ring is flat within `limit_deg` (see
/// [`super::DenoiseParams::flat_skip_deg`]), with the 2-ring's area-weighted mean
/// normal; `None` for the others.
pub fn flat_patches(mesh: &Mesh, topology: &Topology, limit_deg: f64) -> Vec<Option<Vec3>> {
    let geometry = FaceGeometry::new(mesh);
    let n = mesh.num_faces();
    let cos_limit = limit_deg.to_radians().cos();
    (0..n)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || (vec![false; n], Vec::new()),
            |(mark, ring), f| {
                topology.face_ring_into(f, 2, mark, ring);
                let mut sum = [0.0; 3];
                for &g in ring.iter() {
                    let g = g as usize;
                    sum = vec3::add(sum, vec3::scale(geometry.normals[g], geometry.areas[g]));
                }
                let mean = vec3::normalize_or_zero(sum);
                let flat = mean != [0.0; 3]
                    && ring
                        .iter()
                        .all(|&g| vec3::dot(geometry.normals[g as usize], mean) >= cos_limit);
                flat.then_some(mean)
            },
        )
        .collect()
}

/// [`flat_patches`] applied to `normals` (len #F): the flat faces' entries
/// become their 2-ring means. Returns which faces were flat.
pub fn take_flat_means(
    mesh: &Mesh,
    topology: &Topology,
    limit_deg: f64,
    normals: &mut [Vec3],
) -> Vec<bool> {
    flat_patches(mesh, topology, limit_deg)
        .into_iter()
        .zip(normals.iter_mut())
        .map(|(mean, normal)| {
            if let Some(mean) = mean {
                *normal = mean;
            }
            mean.is_some()
        })
        .collect()
}
