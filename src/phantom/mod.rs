//! Analytic phantoms: shapes with a known surface, sampled as CT slices.
