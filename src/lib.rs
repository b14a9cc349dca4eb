//! frameid: identification of mass, stiffness and damping matrices of
//! shear-frame building models from impact-hammer tests.

pub mod records;
