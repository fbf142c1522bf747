//! NormalNet network (placeholder while the crate is built).
