//! What job schedulers need from `envlight bake` beyond the library's `bake::schedule`: exit
//! codes that tell a bad input (retrying cannot help) from a device or system failure
//! (retry).

/// Exit code when the only failures were bad inputs (unreadable, truncated, unusable maps):
/// retrying cannot help; the manifest names them (sysexits' EX_DATAERR).
pub const EXIT_BAD_INPUT: i32 = 65;
/// Exit code for a device or system failure (no device, a lost device, out of memory, a
/// write that failed) or a merge that still misses probes: worth retrying (EX_TEMPFAIL).
pub const EXIT_RETRY: i32 = 75;

/// An error that ends the process with its own exit code.
#[derive(Debug)]
pub struct Exit {
    /// The process's exit code.
    pub code: i32,
    /// What to print.
    pub message: String,
}

impl std::fmt::Display for Exit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Exit {}

pub use crate::bake::manifest::Failure;

/// The exit for a run whose failures were `failures` (one per failed probe): none, only bad
/// inputs ([`EXIT_BAD_INPUT`]), or some system failure ([`EXIT_RETRY`]).
pub fn exit_for(failures: &[Failure], message: String) -> Option<Exit> {
    if failures.is_empty() {
        return None;
    }
    let code = match failures.iter().all(|f| *f == Failure::Input) {
        true => EXIT_BAD_INPUT,
        false => EXIT_RETRY,
    };
    Some(Exit { code, message })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exits_tell_bad_inputs_from_the_system() {
        use Failure::{Input, System};
        assert!(exit_for(&[], String::new()).is_none());
        assert_eq!(
            exit_for(&[Input, Input], String::new()).unwrap().code,
            EXIT_BAD_INPUT
        );
        assert_eq!(
            exit_for(&[Input, System], String::new()).unwrap().code,
            EXIT_RETRY
        );
    }
}
