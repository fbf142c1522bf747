//! The NormalNet method of `normalnet denoise` (not built yet).
