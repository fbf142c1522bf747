//! `Csr`: compressed sparse rows, the flat form of "a list of indices per element".

/// A list of `u32` indices per row, stored flat: row `i` is
/// `indices[offsets[i]..offsets[i + 1]]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Csr {
    /// `#rows + 1` offsets into `indices`, starting at 0
    pub offsets: Vec<u32>,
    /// all rows' indices, concatenated
    pub indices: Vec<u32>,
}

impl Csr {
    /// Builds from one `Vec` per row.
    pub fn from_rows<I: IntoIterator<Item = Vec<u32>>>(rows: I) -> Csr {
        let mut offsets = vec![0u32];
        let mut indices = Vec::new();
        for row in rows {
            indices.extend_from_slice(&row);
            offsets.push(indices.len() as u32);
        }
        Csr { offsets, indices }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.indices[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}
