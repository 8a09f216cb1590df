//! DICOM input: header scan, series grouping and sorting, pixel decoding to HU, phantom writer.
