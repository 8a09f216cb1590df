//! Process exit codes, documented in the README.
//!
//! 0 success; 1 the input could not be processed (bad or missing data, a failed stage);
//! 2 usage error (bad arguments, from clap); 3 an output could not be written;
//! 130 interrupted (Ctrl-C). A closed stdout (broken pipe) is not an error.

use crate::error::Error;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExitCode {
    Success = 0,
    InputError = 1,
    Usage = 2,
    OutputError = 3,
    Interrupted = 130,
}

impl ExitCode {
    pub fn of(err: &Error) -> ExitCode {
        match err {
            Error::Cancelled => ExitCode::Interrupted,
            Error::Io { source, .. } if source.kind() == std::io::ErrorKind::BrokenPipe => {
                ExitCode::Success
            }
            Error::Output { .. } => ExitCode::OutputError,
            Error::Usage { .. } => ExitCode::Usage,
            _ => ExitCode::InputError,
        }
    }
}

impl From<ExitCode> for std::process::ExitCode {
    fn from(c: ExitCode) -> Self {
        std::process::ExitCode::from(c as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cancellation_maps_to_130_and_broken_pipe_to_success() {
        assert_eq!(ExitCode::of(&Error::Cancelled) as u8, 130);
        let e = Error::io("-", std::io::Error::from(std::io::ErrorKind::BrokenPipe));
        assert_eq!(ExitCode::of(&e), ExitCode::Success);
        let e = Error::bad_input("x.dcm", "truncated");
        assert_eq!(ExitCode::of(&e), ExitCode::InputError);
    }
}
