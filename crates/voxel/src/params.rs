//! `VoxelParams`: grid resolution and cube size of the voxelization
//! (paper §3.3, SPEC §5 presets).

use crate::error::VoxelError;

/// Parameters of the voxel grid around one face (SPEC §5).
///
/// The grid has `(2·T_s+1)³` cubes of side `L_c = d_s / α_c`; its spatial
/// extent `(2·T_s+1)·L_c ≈ 5·d_s` is about the same in all three presets.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VoxelParams {
    /// `T_s`: the grid has cubes `B_{x,y,z}`, `x, y, z ∈ [−T_s, T_s]`
    /// (paper: 20; default: the `lite` preset's 10).
    pub t_s: usize,
    /// `α_c`: cube side `L_c = d_s / α_c` (paper: 8; default: `lite`'s 4).
    pub alpha_c: f64,
}

impl Default for VoxelParams {
    /// The `lite` preset, the CPU default (SPEC §5).
    fn default() -> Self {
        Self::lite()
    }
}

impl VoxelParams {
    /// The paper's setting: `T_s = 20`, `α_c = 8`, a 41³ grid.
    pub fn paper() -> Self {
        VoxelParams {
            t_s: 20,
            alpha_c: 8.0,
        }
    }

    /// CPU default: `T_s = 10`, `α_c = 4`, a 21³ grid.
    pub fn lite() -> Self {
        VoxelParams {
            t_s: 10,
            alpha_c: 4.0,
        }
    }

    /// Tests and very large meshes: `T_s = 7`, `α_c = 3`, a 15³ grid.
    pub fn tiny() -> Self {
        VoxelParams {
            t_s: 7,
            alpha_c: 3.0,
        }
    }

    /// The preset called `name` (`paper`, `lite` or `tiny`).
    ///
    /// # Errors
    /// [`VoxelError::InvalidParameter`] naming `preset` for any other name.
    pub fn from_name(name: &str) -> Result<Self, VoxelError> {
        match name {
            "paper" => Ok(Self::paper()),
            "lite" => Ok(Self::lite()),
            "tiny" => Ok(Self::tiny()),
            other => Err(VoxelError::InvalidParameter {
                name: "preset",
                message: format!("unknown preset {other:?} (expected paper, lite or tiny)"),
            }),
        }
    }

    /// The name of the preset these parameters equal, if any.
    pub fn preset_name(&self) -> Option<&'static str> {
        ["paper", "lite", "tiny"]
            .into_iter()
            .find(|n| Self::from_name(n).ok().as_ref() == Some(self))
    }

    /// Cubes along one grid axis: `D = H = W = 2·T_s + 1`.
    pub fn side(&self) -> usize {
        2 * self.t_s + 1
    }

    /// Cubes in the grid: `side³`.
    pub fn num_cells(&self) -> usize {
        self.side().pow(3)
    }

    /// Length of one `[3, D, H, W]` f32 grid: `3·side³`.
    pub fn grid_len(&self) -> usize {
        3 * self.num_cells()
    }

    /// Checks the ranges: `1 ≤ T_s ≤ 64`, `α_c` finite and in `(0, 100]`.
    ///
    /// # Errors
    /// [`VoxelError::InvalidParameter`] naming `t_s` or `alpha_c`.
    pub fn validate(&self) -> Result<(), VoxelError> {
        if self.t_s == 0 || self.t_s > 64 {
            return Err(VoxelError::InvalidParameter {
                name: "t_s",
                message: format!("T_s = {} must be in 1..=64", self.t_s),
            });
        }
        if !(self.alpha_c.is_finite() && self.alpha_c > 0.0 && self.alpha_c <= 100.0) {
            return Err(VoxelError::InvalidParameter {
                name: "alpha_c",
                message: format!("α_c = {} must be finite and in (0, 100]", self.alpha_c),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_and_sizes() {
        assert_eq!(VoxelParams::paper().side(), 41);
        assert_eq!(VoxelParams::lite().grid_len(), 3 * 21 * 21 * 21);
        assert_eq!(VoxelParams::from_name("tiny").unwrap(), VoxelParams::tiny());
        assert_eq!(VoxelParams::lite().preset_name(), Some("lite"));
        let err = VoxelParams::from_name("huge").unwrap_err().to_string();
        assert!(err.contains("preset") && err.contains("huge"), "{err}");
        for p in [
            VoxelParams::paper(),
            VoxelParams::lite(),
            VoxelParams::tiny(),
        ] {
            p.validate().unwrap();
        }
        let bad = VoxelParams {
            t_s: 0,
            alpha_c: 4.0,
        };
        assert!(bad.validate().unwrap_err().to_string().contains("t_s"));
        let bad = VoxelParams {
            t_s: 3,
            alpha_c: f64::NAN,
        };
        assert!(bad.validate().unwrap_err().to_string().contains("alpha_c"));
    }
}
