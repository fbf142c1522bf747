//! The voxelization of one face's neighbourhood (paper §3.3, SPEC §5).
//!
//! Zhao et al., "NormalNet: Learning-based normal filtering for mesh
//! denoising", §3.3 "The voxelization strategy" (arXiv:1903.04015):
//!
//! 1. `n̄` = area-weighted mean normal of the 2-ring patch of f;
//! 2. `W_r` = minimal rotation `n̄ → N_t = (0, 1, 0)` (Rodrigues), optional
//!    yaw about y, `c_f` translated to the origin ([`Frame`]);
//! 3. `(2T_s+1)³` cubes of side `L_c = d_s / α_c`, cube `(0, 0, 0)` centred
//!    at the origin;
//! 4. each candidate face is tested (Akenine-Möller SAT,
//!    [`crate::tri_box_overlap`]) against the cubes of its bounding box only;
//! 5. a cube holds the mean of the rotated unit normals of the faces that
//!    overlap it, `(0, 0, 0)` if none. Degenerate faces (zero normal) are
//!    skipped.
//!
//! Candidates (SPEC §5 step 3, "enough rings to cover the grid half-width
//! `(T_s+½)·L_c`"): instead of one ring radius for the whole mesh, rings are
//! grown per face until they stop meeting the grid. Faces are gathered ring
//! by ring from f through vertex adjacency, and only faces whose bounding box
//! meets the grid seed the next ring. This is the r-ring patch with `r` just
//! large enough for that face (3 for the paper preset on a uniform mesh, more
//! where sampling is dense), so the grid is covered on irregular meshes too,
//! and fewer faces are visited than with a fixed 3-ring. Surface parts that
//! enter the grid without a connection through the grid (another component,
//! a fold far along the surface) are not voxelized.
//!
//! Grid layout: `[3, D, H, W]` f32, channel-major, `D = H = W = 2T_s+1`;
//! D runs along local x, H along local y (the mean-normal direction), W
//! along local z. Cell `(i, j, k)` is centred at local
//! `((i − T_s)·L_c, (j − T_s)·L_c, (k − T_s)·L_c)`, and channel `c` of that
//! cell sits at `c·side³ + (i·side + j)·side + k`.

use crate::error::VoxelError;
use crate::frame::{Frame, mat_vec};
use crate::params::VoxelParams;
use crate::tri_box_overlap::CubeTester;
use normalnet_mesh::geometry::{mean_centre_distance, mean_edge_length};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Csr, FaceGeometry, Mesh, Topology};
use rayon::prelude::*;

/// Everything needed to voxelize the faces of one mesh state: a copy of
/// the mesh and of its vertex-adjacency, the per-face geometry, `d_s`, the
/// 2-ring mean normals. Positions change between NormalNet iterations: build
/// a new one per iteration.
#[derive(Clone, Debug)]
pub struct Voxelizer {
    params: VoxelParams,
    mesh: Mesh,
    neighbours: Csr,
    geometry: FaceGeometry,
    mean_normals: Vec<Vec3>,
    d_s: f64,
    l_e: f64,
    l_c: f64,
}

/// Reusable per-thread buffers of [`Voxelizer::voxelize_face_with`], so that
/// voxelizing a face allocates nothing. Create one per thread and reuse it
/// across faces (and across voxelizers).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    stamp: Vec<u32>,
    generation: u32,
    queue: Vec<u32>,
    counts: Vec<u32>,
    /// per cube, channels-last: the sum of the normals of the faces that
    /// overlap it (zero again once the face is written out)
    sums: Vec<[f32; 3]>,
    /// a bit per cube, zero between faces
    bits: Vec<u64>,
    /// the cubes summed into since the last face, in the order first
    /// touched: the first `touched` entries (len `side³ + 1`)
    touched_cells: Vec<u32>,
    touched: usize,
    /// the cubes one candidate face overlaps
    hits: Vec<u32>,
    occupied: usize,
    candidates: usize,
    visited: usize,
}

impl Scratch {
    /// Empty buffers (they grow on first use).
    pub fn new() -> Scratch {
        Scratch::default()
    }

    /// Number of non-empty cubes of the last voxelized face.
    pub fn last_occupied(&self) -> usize {
        self.occupied
    }

    /// Number of faces voxelized (non-degenerate, bounding box meeting the
    /// grid) for the last face.
    pub fn last_candidates(&self) -> usize {
        self.candidates
    }

    /// Number of faces visited (tested against the grid) for the last face.
    pub fn last_visited(&self) -> usize {
        self.visited
    }

    /// The mean of the normals summed into `cell`, which is left empty
    /// again (count and sum zero) for the next face.
    fn take_mean(&mut self, cell: usize) -> [f32; 3] {
        let count = std::mem::replace(&mut self.counts[cell], 0);
        let sum = std::mem::replace(&mut self.sums[cell], [0.0; 3]);
        let s = 1.0 / count as f32;
        sum.map(|v| v * s)
    }

    fn prepare(&mut self, num_faces: usize, num_cells: usize) {
        if self.stamp.len() < num_faces {
            self.stamp = vec![0; num_faces];
            self.generation = 0;
        }
        if self.counts.len() != num_cells {
            self.counts = vec![0; num_cells];
            self.sums = vec![[0.0; 3]; num_cells];
            // one more: the slot a repeat visit writes when all are touched
            self.touched_cells = vec![0; num_cells + 1];
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.generation = 1;
        }
        self.queue.clear();
        self.touched = 0;
    }

    /// The cubes summed into since the last face, in the order first touched.
    fn touched(&self) -> &[u32] {
        &self.touched_cells[..self.touched]
    }
}

impl Voxelizer {
    /// Precomputes the per-pass geometry of `mesh` (connectivity `topology`).
    ///
    /// # Errors
    /// [`VoxelError::InvalidParameter`] from [`VoxelParams::validate`];
    /// [`VoxelError::TopologyMismatch`] when `topology` is not `mesh`'s;
    /// [`VoxelError::NoScale`] when `d_s` is zero (no edge-adjacent faces).
    pub fn new(
        mesh: &Mesh,
        topology: &Topology,
        params: VoxelParams,
    ) -> Result<Voxelizer, VoxelError> {
        params.validate()?;
        if topology.num_faces() != mesh.num_faces() || topology.num_vertices != mesh.num_vertices()
        {
            return Err(VoxelError::TopologyMismatch {
                topology_faces: topology.num_faces(),
                topology_vertices: topology.num_vertices,
                mesh_faces: mesh.num_faces(),
                mesh_vertices: mesh.num_vertices(),
            });
        }
        let geometry = FaceGeometry::new(mesh);
        let d_s = mean_centre_distance(topology, &geometry.centres);
        if !(d_s > 0.0 && d_s.is_finite()) {
            return Err(VoxelError::NoScale { d_s });
        }
        let l_e = mean_edge_length(mesh, topology);
        let mean_normals = ring2_mean_normals(topology, &geometry);
        Ok(Voxelizer {
            params,
            mesh: mesh.clone(),
            neighbours: topology.face_neighbours.clone(),
            geometry,
            mean_normals,
            d_s,
            l_e,
            l_c: d_s / params.alpha_c,
        })
    }

    /// The grid parameters.
    pub fn params(&self) -> VoxelParams {
        self.params
    }

    /// Number of faces of the mesh.
    pub fn num_faces(&self) -> usize {
        self.mesh.num_faces()
    }

    /// `d_s`: mean distance between the centres of edge-adjacent faces.
    pub fn d_s(&self) -> f64 {
        self.d_s
    }

    /// `l_e`: mean edge length.
    pub fn l_e(&self) -> f64 {
        self.l_e
    }

    /// `L_c = d_s / α_c`: the cube side.
    pub fn cube_side(&self) -> f64 {
        self.l_c
    }

    /// Normals, areas, centres of the mesh state.
    pub fn geometry(&self) -> &FaceGeometry {
        &self.geometry
    }

    /// `n̄`: the normalised area-weighted mean normal of each face's 2-ring
    /// (zero where the whole 2-ring is degenerate; len #F).
    pub fn mean_normals(&self) -> &[Vec3] {
        &self.mean_normals
    }

    /// The frame of face `f` with yaw `yaw` (radians).
    ///
    /// # Panics
    /// If `f >= num_faces()`.
    pub fn frame(&self, f: usize, yaw: f64) -> Frame {
        Frame::new(self.mean_normals[f], self.geometry.centres[f], yaw)
    }

    /// Voxelizes face `f` (no yaw) into `out` (len `grid_len()`), allocating
    /// its scratch: use [`Self::voxelize_face_with`] in loops.
    ///
    /// # Panics
    /// If `f` is out of range or `out.len() != params().grid_len()`.
    pub fn voxelize_face(&self, f: usize, out: &mut [f32]) -> Frame {
        self.voxelize_face_with(&mut Scratch::new(), f, 0.0, out)
    }

    /// Voxelizes face `f` with yaw `yaw` (radians) into `out`, allocating
    /// its scratch.
    ///
    /// # Panics
    /// If `f` is out of range or `out.len() != params().grid_len()`.
    pub fn voxelize_face_yaw(&self, f: usize, yaw: f64, out: &mut [f32]) -> Frame {
        self.voxelize_face_with(&mut Scratch::new(), f, yaw, out)
    }

    /// Voxelizes face `f` in the frame `Y(yaw)·W_r` into `out`: the
    /// `[3, D, H, W]` grid described in the module docs. Returns the frame.
    ///
    /// Time: O(candidate faces × cubes of their bounding boxes) plus
    /// clearing `out`.
    ///
    /// # Panics
    /// If `f` is out of range or `out.len() != params().grid_len()`.
    pub fn voxelize_face_with(
        &self,
        scratch: &mut Scratch,
        f: usize,
        yaw: f64,
        out: &mut [f32],
    ) -> Frame {
        let grid_len = self.params.grid_len();
        assert_eq!(
            out.len(),
            grid_len,
            "grid buffer has len {}, expected 3·side³ = {grid_len}",
            out.len()
        );
        let frame = self.accumulate(scratch, f, yaw);
        let cells = grid_len / 3;
        out.fill(0.0);
        for i in 0..scratch.touched {
            let cell = scratch.touched_cells[i] as usize;
            for (c, v) in scratch.take_mean(cell).into_iter().enumerate() {
                out[c * cells + cell] = v;
            }
        }
        frame
    }

    /// [`Self::voxelize_face_with`] into a [`SparseGrid`]: only the cubes
    /// with a non-zero channel (the same values as in the dense grid).
    /// Time: O(candidate faces × cubes of their bounding boxes) plus a
    /// pass over a bit per cube (the occupied cubes in ascending order);
    /// nothing of size `side³` is cleared.
    ///
    /// # Panics
    /// If `f` is out of range.
    pub fn voxelize_face_sparse(
        &self,
        scratch: &mut Scratch,
        f: usize,
        yaw: f64,
        out: &mut SparseGrid,
    ) -> Frame {
        let frame = self.accumulate(scratch, f, yaw);
        out.cells.clear();
        out.values.clear();
        // the touched cubes in ascending order from a bit per cube of the
        // grid (145 words at 21³) instead of a sort
        let mut bits = std::mem::take(&mut scratch.bits);
        bits.resize(scratch.counts.len().div_ceil(64), 0);
        for &cell in scratch.touched() {
            bits[cell as usize / 64] |= 1 << (cell % 64);
        }
        for (w, word) in bits.iter_mut().enumerate() {
            while *word != 0 {
                let c = 64 * w + word.trailing_zeros() as usize;
                *word &= *word - 1;
                let v = scratch.take_mean(c);
                if v.iter().any(|&v| v != 0.0) {
                    out.cells.push(c as u32);
                    out.values.extend_from_slice(&v);
                }
            }
        }
        // all zero again
        scratch.bits = bits;
        frame
    }

    /// Sums, per cube of face `f`'s grid, the rotated normals of the faces
    /// overlapping it into `scratch` (`sums`, `counts`, `touched`).
    fn accumulate(&self, scratch: &mut Scratch, f: usize, yaw: f64) -> Frame {
        let n_faces = self.num_faces();
        assert!(
            f < n_faces,
            "face {f} out of range (mesh has {n_faces} faces)"
        );
        let side = self.params.side();
        let cells = side * side * side;
        let frame = self.frame(f, yaw);
        scratch.prepare(n_faces, cells);
        // Local grid units: q = M (p − c_f) + (T_s + ½), cube (i,j,k) = [i,i+1]×….
        let inv = 1.0 / self.l_c;
        let m = frame.rotation.map(|row| vec3::scale(row, inv));
        let shift = self.params.t_s as f64 + 0.5;
        let to_grid = |p: Vec3| {
            let q = mat_vec(&m, vec3::sub(p, frame.centre));
            [q[0] + shift, q[1] + shift, q[2] + shift]
        };
        let limit = side as f64;
        let stamp = scratch.generation;
        scratch.stamp[f] = stamp;
        scratch.queue.push(f as u32);
        let mut head = 0;
        let mut candidates = 0;
        while head < scratch.queue.len() {
            let g = scratch.queue[head] as usize;
            head += 1;
            let [a, b, c] = self.mesh.corners(g);
            let tri = [to_grid(a), to_grid(b), to_grid(c)];
            let tester = CubeTester::new(tri);
            let meets_grid = (0..3).all(|ax| tester.lo[ax] <= limit && tester.hi[ax] >= 0.0);
            if !meets_grid && g != f {
                continue;
            }
            for &h in self.neighbours.row(g) {
                let s = &mut scratch.stamp[h as usize];
                if *s != stamp {
                    *s = stamp;
                    scratch.queue.push(h);
                }
            }
            let n_g = self.geometry.normals[g];
            if n_g == [0.0; 3] {
                continue;
            }
            let Some(range) = tester.cube_range(side) else {
                continue;
            };
            candidates += 1;
            let n_local = frame.to_local(n_g);
            let n_local = [n_local[0] as f32, n_local[1] as f32, n_local[2] as f32];
            scratch.hits.clear();
            tester.overlapped_cells(range, side, &mut scratch.hits);
            for &cell in &scratch.hits {
                let cell = cell as usize;
                let count = &mut scratch.counts[cell];
                // appended where first touched (no branch: the slot is
                // overwritten otherwise)
                scratch.touched_cells[scratch.touched] = cell as u32;
                scratch.touched += usize::from(*count == 0);
                *count += 1;
                let sum = &mut scratch.sums[cell];
                for (s, v) in sum.iter_mut().zip(n_local) {
                    *s += v;
                }
            }
        }
        scratch.occupied = scratch.touched;
        scratch.candidates = candidates;
        scratch.visited = scratch.queue.len();
        frame
    }

    /// Voxelizes `faces` in parallel (yaw 0) into `out`, which holds
    /// `faces.len()` grids back to back (len `faces.len() · grid_len()`).
    /// Returns one frame per face. Results do not depend on the thread count.
    ///
    /// # Panics
    /// If a face is out of range or `out` has the wrong length.
    pub fn voxelize_batch(&self, faces: &[u32], out: &mut [f32]) -> Vec<Frame> {
        self.voxelize_batch_yaw(faces, None, out)
    }

    /// [`Self::voxelize_batch`] with one yaw per face (`yaws.len() ==
    /// faces.len()`), or none.
    ///
    /// # Panics
    /// If a face is out of range, `out` or `yaws` has the wrong length.
    pub fn voxelize_batch_yaw(
        &self,
        faces: &[u32],
        yaws: Option<&[f64]>,
        out: &mut [f32],
    ) -> Vec<Frame> {
        let grid_len = self.params.grid_len();
        assert_eq!(
            out.len(),
            faces.len() * grid_len,
            "batch buffer must hold faces.len() grids"
        );
        let grids = out.par_chunks_mut(grid_len);
        per_face(faces, yaws, grids, |scratch, f, yaw, grid| {
            self.voxelize_face_with(scratch, f, yaw, grid)
        })
    }

    /// [`Self::voxelize_batch_yaw`] into sparse grids: `out` is resized to
    /// one [`SparseGrid`] per face (their buffers reused).
    ///
    /// # Panics
    /// If a face is out of range or `yaws` has the wrong length.
    pub fn voxelize_batch_sparse(
        &self,
        faces: &[u32],
        yaws: Option<&[f64]>,
        out: &mut Vec<SparseGrid>,
    ) -> Vec<Frame> {
        out.resize_with(faces.len(), SparseGrid::default);
        per_face(faces, yaws, out.par_iter_mut(), |scratch, f, yaw, grid| {
            self.voxelize_face_sparse(scratch, f, yaw, grid)
        })
    }
}

/// `voxelize(scratch, face, yaw, grid)` for every face of `faces` (in
/// parallel, one scratch per worker) into the grid of the same position in
/// `grids`, with its yaw of `yaws` (or 0); the faces' frames.
///
/// # Panics
/// If `yaws` has the wrong length.
fn per_face<G: Send>(
    faces: &[u32],
    yaws: Option<&[f64]>,
    grids: impl IndexedParallelIterator<Item = G>,
    voxelize: impl Fn(&mut Scratch, usize, f64, G) -> Frame + Sync + Send,
) -> Vec<Frame> {
    if let Some(y) = yaws {
        assert_eq!(y.len(), faces.len(), "one yaw per face");
    }
    grids
        .zip(faces.par_iter())
        .enumerate()
        .map_init(Scratch::new, |scratch, (idx, (grid, &f))| {
            voxelize(scratch, f as usize, yaws.map_or(0.0, |y| y[idx]), grid)
        })
        .collect()
}

/// The non-empty cubes of one grid: what the dense `[3, D, H, W]` grid
/// holds, without its zeros.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseGrid {
    /// cube indices `(i·side + j)·side + k`, ascending
    pub cells: Vec<u32>,
    /// the three channels of each cube of `cells`, cube after cube
    pub values: Vec<f32>,
}

/// `n̄` for every face: normalised `Σ a_g n_g` over the 2-ring patch
/// (zero where that sum vanishes).
fn ring2_mean_normals(topology: &Topology, geometry: &FaceGeometry) -> Vec<Vec3> {
    let n = topology.num_faces();
    (0..n)
        .into_par_iter()
        .map_init(
            || (vec![false; n], Vec::new()),
            |(mark, ring), f| {
                topology.face_ring_into(f, 2, mark, ring);
                let mut s = [0.0; 3];
                for &g in ring.iter() {
                    s = vec3::add(
                        s,
                        vec3::scale(geometry.normals[g as usize], geometry.areas[g as usize]),
                    );
                }
                vec3::normalize_or_zero(s)
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat n×n grid of squares in the plane z = 0 (two triangles each).
    pub(crate) fn flat_patch(n: usize, jitter: f64) -> Mesh {
        Mesh::grid(n, |i, j| {
            let d = if (i + j) % 2 == 0 { jitter } else { -jitter };
            [i as f64 + d, j as f64 - 0.5 * d, 0.0]
        })
    }

    #[test]
    fn flat_plane_gives_one_layer_of_up_normals() {
        let mesh = flat_patch(30, 0.13);
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        for params in [
            VoxelParams::tiny(),
            VoxelParams::lite(),
            VoxelParams::paper(),
        ] {
            let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
            let side = params.side();
            let cells = side.pow(3);
            let mut grid = vec![0.0f32; params.grid_len()];
            let mut scratch = Scratch::new();
            let f = 2 * (15 * 30 + 15);
            vox.voxelize_face_with(&mut scratch, f, 0.0, &mut grid);
            let mut occupied = 0;
            for i in 0..side {
                for j in 0..side {
                    for k in 0..side {
                        let cell = (i * side + j) * side + k;
                        let v = [grid[cell], grid[cells + cell], grid[2 * cells + cell]];
                        if j == params.t_s {
                            // The patch covers the whole grid footprint.
                            assert!(
                                (v[0].abs() + v[2].abs()) < 1e-6 && (v[1] - 1.0).abs() < 1e-6,
                                "{v:?}"
                            );
                            occupied += 1;
                        } else {
                            assert_eq!(v, [0.0; 3], "cell {i} {j} {k}");
                        }
                    }
                }
            }
            assert_eq!(occupied, side * side);
            assert_eq!(scratch.last_occupied(), side * side);
        }
    }

    #[test]
    fn sparse_grids_hold_the_dense_grids_non_zero_cubes() {
        // a bumpy surface: cubes shared by faces of different normals
        let mut mesh = flat_patch(16, 0.2);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            p[2] = ((i * 7919) % 13) as f64 * 0.04;
        }
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let params = VoxelParams::lite();
        let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
        let faces: Vec<u32> = (0..mesh.num_faces() as u32).step_by(5).collect();
        let yaws: Vec<f64> = faces.iter().map(|&f| f as f64 * 0.1).collect();
        let mut dense = vec![0.0f32; faces.len() * params.grid_len()];
        let frames = vox.voxelize_batch_yaw(&faces, Some(&yaws), &mut dense);
        // the buffers of an earlier, larger batch are reused
        let mut sparse = vec![SparseGrid::default(); faces.len() + 3];
        sparse[0].cells.push(5);
        let sparse_frames = vox.voxelize_batch_sparse(&faces, Some(&yaws), &mut sparse);
        assert_eq!(frames, sparse_frames);
        assert_eq!(sparse.len(), faces.len());
        let cells = params.side().pow(3);
        for (grid, s) in dense.chunks_exact(params.grid_len()).zip(&sparse) {
            let want: Vec<u32> = (0..cells)
                .filter(|&c| (0..3).any(|ch| grid[ch * cells + c] != 0.0))
                .map(|c| c as u32)
                .collect();
            assert!(!want.is_empty());
            assert_eq!(s.cells, want);
            for (i, &c) in s.cells.iter().enumerate() {
                for ch in 0..3 {
                    let d = grid[ch * cells + c as usize];
                    assert_eq!(s.values[3 * i + ch].to_bits(), d.to_bits());
                }
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        let mesh = flat_patch(2, 0.0);
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let bad = VoxelParams {
            t_s: 0,
            alpha_c: 1.0,
        };
        assert!(
            Voxelizer::new(&mesh, &topo, bad)
                .unwrap_err()
                .to_string()
                .contains("t_s")
        );
        let other = Topology::new(3, &[[0, 1, 2]]);
        assert!(matches!(
            Voxelizer::new(&mesh, &other, VoxelParams::tiny()),
            Err(VoxelError::TopologyMismatch { .. })
        ));
        let single = Mesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let t = Topology::new(3, &single.faces);
        assert!(matches!(
            Voxelizer::new(&single, &t, VoxelParams::tiny()),
            Err(VoxelError::NoScale { .. })
        ));
    }

    #[test]
    fn degenerate_faces_are_skipped_without_nan() {
        let mut mesh = flat_patch(12, 0.0);
        // Collapse one vertex onto its neighbour: two faces become degenerate.
        let v = 6 * 13 + 6;
        mesh.positions[v] = mesh.positions[v + 1];
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let vox = Voxelizer::new(&mesh, &topo, VoxelParams::tiny()).unwrap();
        let faces: Vec<u32> = (0..mesh.num_faces() as u32).collect();
        let mut out = vec![0.0f32; faces.len() * VoxelParams::tiny().grid_len()];
        vox.voxelize_batch(&faces, &mut out);
        assert!(out.iter().all(|x| x.is_finite()));
        // Every non-empty cell is a unit normal (0, 1, 0) on this flat mesh.
        let cells = VoxelParams::tiny().num_cells();
        for g in out.chunks(3 * cells) {
            for c in 0..cells {
                let y = g[cells + c];
                assert!(y == 0.0 || (y - 1.0).abs() < 1e-6);
            }
        }
    }
}
