//! Training samples (paper §4, SPEC §8): a voxel grid of a face of the
//! current (noisy) mesh paired with its six GT-guided GNF target normals in
//! the same local frame, and the `A_p` balance categories.
//!
//! Targets: one GT-guided GNF pass (SPEC §4; `normalnet_filters::
//! try_gt_guided_normals`, `μ_d = 2·d_s`) on the noisy mesh with the
//! ground-truth face normals as guidance, for each `μ_g` in [`MU_GS`].
//! `A_p(f)`: the largest angle between the ground-truth normal of f and that
//! of any face of f's 2-ring (clean mesh); categories `> 80°`, `50–80°`,
//! `20–50°`, `≤ 20°` ([`A_P_EDGES`]), balanced to equal counts in training.
//! Faces with a zero ground-truth normal (degenerate in the clean mesh) or a
//! zero target are in no category: they are never sampled.

use crate::error::SampleError;
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Topology};
use normalnet_voxel::{Frame, Scratch, VoxelParams, Voxelizer};
use rayon::prelude::*;

/// The six `μ_g` of the network outputs (SPEC §6).
pub const MU_GS: [f64; 6] = [0.25, 0.30, 0.35, 0.40, 0.45, 0.50];

/// Number of target normals per sample (`MU_GS.len()`).
pub const NUM_TARGETS: usize = 6;

/// Length of a sample's target vector: three floats per target.
pub const TARGET_LEN: usize = 3 * NUM_TARGETS;

/// Spatial width of the GT-guided targets in units of `d_s` (the paper's
/// `μ_d = 2·d_s`, SPEC §4).
pub const TARGET_SIGMA_S_OVER_DS: f64 = 2.0;

/// Category edges of `A_p` in degrees: category 0 is `A_p > 80°`, 1 is
/// `50° < A_p ≤ 80°`, 2 is `20° < A_p ≤ 50°`, 3 is `A_p ≤ 20°`.
pub const A_P_EDGES: [f64; 3] = [20.0, 50.0, 80.0];

/// Number of `A_p` categories.
pub const NUM_CATEGORIES: usize = 4;

/// The category of an `A_p` angle in degrees (see [`A_P_EDGES`]).
pub fn a_p_category(a_p_degrees: f64) -> usize {
    if a_p_degrees > A_P_EDGES[2] {
        0
    } else if a_p_degrees > A_P_EDGES[1] {
        1
    } else if a_p_degrees > A_P_EDGES[0] {
        2
    } else {
        3
    }
}

/// Marker in [`SampleSource::categories`] for faces that are never sampled.
pub const NO_CATEGORY: u8 = u8::MAX;

/// One training mesh state: the voxelizer of the noisy (current) mesh, the
/// GT-guided targets (world frame) and the `A_p` categories of its faces.
#[derive(Clone, Debug)]
pub struct SampleSource {
    voxelizer: Voxelizer,
    mu_gs: [f64; NUM_TARGETS],
    targets: Vec<Vec3>,
    a_p: Vec<f64>,
    category: Vec<u8>,
    category_faces: [Vec<u32>; NUM_CATEGORIES],
    residual: bool,
}

impl SampleSource {
    /// With `on`, [`Self::sample`] gives each target minus the face's
    /// current normal (both in the local frame): the residual a network
    /// with residual output learns (it predicts `target − input`).
    pub fn with_residual(mut self, on: bool) -> SampleSource {
        self.residual = on;
        self
    }

    /// The current (noisy) normal of face `f` in `frame`.
    pub fn local_input(&self, frame: &Frame, f: usize) -> [f32; 3] {
        let l = frame.to_local(self.voxelizer.geometry().normals[f]);
        [l[0] as f32, l[1] as f32, l[2] as f32]
    }

    /// Precomputes the topology, voxelizer, targets and categories of the
    /// pair (`noisy`, `clean`), which must share vertex count and faces.
    /// `mu_gs` must hold six values (usually [`MU_GS`]).
    ///
    /// # Errors
    /// [`SampleError::PairMismatch`] when the meshes differ in connectivity;
    /// [`SampleError::InvalidParameter`] when `mu_gs` has not six values or
    /// one is not positive; errors of [`Voxelizer::new`] and of the target
    /// computation.
    pub fn new(
        noisy: Mesh,
        clean: &Mesh,
        params: VoxelParams,
        mu_gs: &[f64],
    ) -> Result<SampleSource, SampleError> {
        if noisy.num_vertices() != clean.num_vertices() || noisy.faces != clean.faces {
            let what = if noisy.num_vertices() != clean.num_vertices() {
                format!(
                    "{} vs {} vertices",
                    noisy.num_vertices(),
                    clean.num_vertices()
                )
            } else if noisy.num_faces() != clean.num_faces() {
                format!("{} vs {} faces", noisy.num_faces(), clean.num_faces())
            } else {
                let f = noisy
                    .faces
                    .iter()
                    .zip(&clean.faces)
                    .position(|(a, b)| a != b)
                    .unwrap_or(0);
                format!(
                    "face {f} is {:?} in the noisy mesh, {:?} in the clean one",
                    noisy.faces[f], clean.faces[f]
                )
            };
            return Err(SampleError::PairMismatch(what));
        }
        let mu: [f64; NUM_TARGETS] =
            mu_gs
                .try_into()
                .map_err(|_| SampleError::InvalidParameter {
                    name: "mu_gs",
                    message: format!("expected {NUM_TARGETS} values of μ_g, got {}", mu_gs.len()),
                })?;
        if let Some(m) = mu.iter().find(|m| !(m.is_finite() && **m > 0.0)) {
            return Err(SampleError::InvalidParameter {
                name: "mu_gs",
                message: format!("μ_g = {m} must be finite and positive"),
            });
        }
        let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
        let voxelizer = Voxelizer::new(&noisy, &topology, params)?;
        let gt = face_normals(clean);
        let targets = normalnet_filters::try_gt_guided_normals(
            &noisy,
            &topology,
            &gt,
            &mu,
            TARGET_SIGMA_S_OVER_DS,
        )?;
        let a_p = a_p_angles(&topology, &gt);
        let category: Vec<u8> = (0..noisy.num_faces())
            .map(|f| {
                let ok = gt[f] != [0.0; 3]
                    && targets[f * NUM_TARGETS..(f + 1) * NUM_TARGETS]
                        .iter()
                        .all(|t| *t != [0.0; 3]);
                if ok {
                    a_p_category(a_p[f]) as u8
                } else {
                    NO_CATEGORY
                }
            })
            .collect();
        let mut category_faces: [Vec<u32>; NUM_CATEGORIES] = Default::default();
        for (f, &c) in category.iter().enumerate() {
            if c != NO_CATEGORY {
                category_faces[c as usize].push(f as u32);
            }
        }
        Ok(SampleSource {
            voxelizer,
            mu_gs: mu,
            targets,
            a_p,
            category,
            category_faces,
            residual: false,
        })
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.voxelizer.num_faces()
    }

    /// The voxelizer of the noisy mesh.
    pub fn voxelizer(&self) -> &Voxelizer {
        &self.voxelizer
    }

    /// The grid parameters.
    pub fn params(&self) -> VoxelParams {
        self.voxelizer.params()
    }

    /// The six `μ_g` of the targets.
    pub fn mu_gs(&self) -> &[f64; NUM_TARGETS] {
        &self.mu_gs
    }

    /// World-frame targets of face `f`, one unit normal per `μ_g`.
    pub fn world_targets(&self, f: usize) -> &[Vec3] {
        &self.targets[f * NUM_TARGETS..(f + 1) * NUM_TARGETS]
    }

    /// `A_p` of every face in degrees (len #F; 0 for faces with a zero GT
    /// normal).
    pub fn a_p(&self) -> &[f64] {
        &self.a_p
    }

    /// Category of every face (0..4, or [`NO_CATEGORY`]; len #F).
    pub fn categories(&self) -> &[u8] {
        &self.category
    }

    /// The faces of category `c` (increasing order).
    ///
    /// # Panics
    /// If `c >= NUM_CATEGORIES`.
    pub fn category_faces(&self, c: usize) -> &[u32] {
        &self.category_faces[c]
    }

    /// Voxelizes face `f` with yaw `yaw` into `grid_out` (len `grid_len()`)
    /// and returns its six targets rotated into the same local frame, as
    /// `[x0, y0, z0, x1, …, z5]`.
    ///
    /// # Panics
    /// If `f` is out of range or `grid_out` has the wrong length.
    pub fn sample(&self, f: usize, yaw: f64, grid_out: &mut [f32]) -> [f32; TARGET_LEN] {
        self.sample_with(&mut Scratch::new(), f, yaw, grid_out).0
    }

    /// [`Self::sample`] with caller scratch; also returns the frame.
    ///
    /// # Panics
    /// If `f` is out of range or `grid_out` has the wrong length.
    pub fn sample_with(
        &self,
        scratch: &mut Scratch,
        f: usize,
        yaw: f64,
        grid_out: &mut [f32],
    ) -> ([f32; TARGET_LEN], Frame) {
        let frame = self.voxelizer.voxelize_face_with(scratch, f, yaw, grid_out);
        (self.local_targets(&frame, f), frame)
    }

    /// The targets of face `f` in `frame` (flattened, see [`Self::sample`];
    /// minus [`Self::local_input`] with [`Self::with_residual`]).
    pub fn local_targets(&self, frame: &Frame, f: usize) -> [f32; TARGET_LEN] {
        let base = if self.residual {
            self.local_input(frame, f)
        } else {
            [0.0; 3]
        };
        let mut out = [0.0f32; TARGET_LEN];
        for (k, t) in self.world_targets(f).iter().enumerate() {
            let l = frame.to_local(*t);
            for a in 0..3 {
                out[3 * k + a] = l[a] as f32 - base[a];
            }
        }
        out
    }
}

/// `A_p` in degrees for every face: the largest angle between `gt[f]` and
/// `gt[g]` over the faces g of f's 2-ring with non-zero normals (0 where
/// `gt[f]` is zero).
pub fn a_p_angles(topology: &Topology, gt: &[Vec3]) -> Vec<f64> {
    let n = topology.num_faces();
    (0..n)
        .into_par_iter()
        .map_init(
            || (vec![false; n], Vec::new()),
            |(mark, ring), f| {
                if gt[f] == [0.0; 3] {
                    return 0.0;
                }
                topology.face_ring_into(f, 2, mark, ring);
                ring.iter()
                    .filter(|&&g| gt[g as usize] != [0.0; 3])
                    .map(|&g| vec3::angle(gt[f], gt[g as usize]).to_degrees())
                    .fold(0.0, f64::max)
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn categories_follow_the_edges() {
        assert_eq!(a_p_category(90.0), 0);
        assert_eq!(a_p_category(80.0), 1);
        assert_eq!(a_p_category(50.1), 1);
        assert_eq!(a_p_category(50.0), 2);
        assert_eq!(a_p_category(20.0), 3);
        assert_eq!(a_p_category(0.0), 3);
    }
}
