//! Stanford PLY: the reader ([`read`]), the writers ([`write`]) and every
//! element and property a PLY file holds beyond positions and faces
//! ([`PlyAttributes`], kept by [`super::read_mesh_file`]).

mod read;
mod write;

pub use read::{Kind as PlyKind, Scalar as PlyScalar};
pub(super) use read::{parse, parse_with_attributes};
pub(super) use write::{write, write_with_attributes};

/// How a PLY file stores its data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyEncoding {
    /// `format ascii 1.0`
    Ascii,
    /// `format binary_little_endian 1.0`
    BinaryLittleEndian,
    /// `format binary_big_endian 1.0`
    BinaryBigEndian,
}

/// A header line other than `ply`, `format`, `property` and `end_header`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlyHeaderLine {
    /// a `comment` or `obj_info` line, as written
    Verbatim(Vec<u8>),
    /// an `element` line (index into [`PlyAttributes::elements`]), followed
    /// by its property lines
    Element(usize),
}

/// Where the values of one property are.
#[derive(Clone, Debug, PartialEq)]
pub enum PlyColumn {
    /// vertex `x`, `y` or `z` (axis 0, 1, 2): the mesh's positions
    Position(usize),
    /// vertex or face `nx`, `ny` or `nz` (axis 0, 1, 2): recomputed from the
    /// written surface on writing (area-weighted)
    Normal(usize),
    /// the face list `vertex_indices`: the mesh's polygons
    FaceIndices,
    /// a scalar property: one value per element instance, exact as `f64`
    Scalars(Vec<f64>),
    /// a list property: each instance's length, and all items in order
    Lists {
        /// one length per instance
        lengths: Vec<u32>,
        /// the items of every instance, one after the other
        items: Vec<f64>,
    },
}

/// One property of an element: its name, type, header line and values.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyProperty {
    /// the property's name
    pub name: String,
    /// its type
    pub kind: PlyKind,
    /// its header line as written (`property float value`)
    pub line: Vec<u8>,
    /// its values, or where they come from
    pub column: PlyColumn,
}

/// One element of a PLY file with all its properties.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyElement {
    /// the element's name (`vertex`, `face`, `edge`, ...)
    pub name: String,
    /// number of instances in the file
    pub count: usize,
    /// its properties in header order
    pub properties: Vec<PlyProperty>,
}

/// Every element and property of a PLY file, in header order.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyAttributes {
    /// the file's encoding (the writer keeps it)
    pub encoding: PlyEncoding,
    /// comments, `obj_info` and elements in header order
    pub header: Vec<PlyHeaderLine>,
    /// the elements in file order
    pub elements: Vec<PlyElement>,
    /// index of the `vertex` element
    pub vertex_element: usize,
    /// index of the `face` element, if any
    pub face_element: Option<usize>,
}

impl PlyAttributes {
    /// The values of the scalar property `name` of element `element`, if
    /// it is kept as values (not a position, normal or the face indices).
    pub fn scalars(&self, element: &str, name: &str) -> Option<&[f64]> {
        let el = self.elements.iter().find(|e| e.name == element)?;
        match &el.properties.iter().find(|p| p.name == name)?.column {
            PlyColumn::Scalars(v) => Some(v),
            _ => None,
        }
    }
}
