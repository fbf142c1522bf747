//! Classical mesh denoisers on one normal-filter + vertex-update skeleton (SPEC §4).
