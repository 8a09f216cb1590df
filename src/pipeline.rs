//! Channel wiring: every stage of a run, connected by bounded channels, in one place.
