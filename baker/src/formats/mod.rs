//! The files the baker reads and writes, and nothing of how their contents are made: the
//! `.prt` coefficient file (a plain [`coefficient_file::Header`] and arrays), NumPy `.npz`,
//! OpenEXR and PLY. The bake fills them ([`crate::bake::file`]); these modules only encode,
//! decode and validate.
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`] (the up axis and the
//! scene fingerprint), [`crate::trace`] (the backend recorded in a header).

pub mod coefficient_file;
pub mod cpca_block;
pub mod encoded;
pub mod header;
pub mod ldprt_file;
pub mod npz;
pub(crate) mod object_placements;
pub mod occluder_file;
pub mod openexr;
pub mod part_id;
pub mod ply;
pub mod png;
pub mod probe_block;
pub mod probe_points;
pub mod receiver_objects;
pub mod receiver_section;
pub mod scene_check;
pub mod versions;
