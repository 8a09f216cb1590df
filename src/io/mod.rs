//! Formats read and written: contour NDJSON, reports, atomic output files.
