//! Run configuration: plain data built by the CLI (the library never depends on clap).
