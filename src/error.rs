//! The library's error type.

use ash::vk;
use std::path::PathBuf;

/// Everything that can go wrong in envlight for reasons outside the caller's control.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its contents are unusable.
    #[error("{}: {problem}", path.display())]
    BadFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it, in words.
        problem: String,
    },
    /// A user-supplied parameter is out of range (a size of zero, an unknown mapping name…).
    #[error("{0}")]
    Invalid(String),
    /// An error of some larger job, with what the job was doing (a probe's path in a set's
    /// bake): "context: error", or the error alone where it already begins with the context
    /// (a bad file's error names its path).
    #[error("{}", context_text(context, inner))]
    Context {
        /// What was being done, or on what.
        context: String,
        /// What went wrong.
        inner: Box<Error>,
    },
    /// The Vulkan loader (libvulkan.so.1) could not be loaded.
    #[error(
        "no Vulkan loader found ({0}); install it with `apt-get install libvulkan1 mesa-vulkan-drivers` \
         (or run `cargo xtask setup`)"
    )]
    NoLoader(String),
    /// The loader works but no usable device is there.
    #[error("{0}")]
    NoDevice(String),
    /// A Vulkan call failed.
    #[error("Vulkan error while {what}: {result}")]
    Vulkan {
        /// What was being done.
        what: &'static str,
        /// The result code.
        result: vk::Result,
    },
    /// GPU memory could not be allocated.
    #[error("GPU memory allocation failed for {what}: {source}")]
    Alloc {
        /// What the memory was for.
        what: String,
        /// gpu-allocator's error.
        #[source]
        source: gpu_allocator::AllocationError,
    },
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Attaches a description to a raw Vulkan result.
pub(crate) trait VkContext<T> {
    fn vk(self, what: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, what: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { what, result })
    }
}

/// [`Error::Context`]'s message: the context said once.
fn context_text(context: &str, inner: &Error) -> String {
    let inner = inner.to_string();
    match inner.strip_prefix(context) {
        Some(rest) if rest.starts_with(':') => inner,
        _ => format!("{context}: {inner}"),
    }
}

impl Error {
    /// This error inside `context` ([`Error::Context`]).
    pub fn context(self, context: impl Into<String>) -> Error {
        Error::Context {
            context: context.into(),
            inner: Box::new(self),
        }
    }

    /// The error under any [`Error::Context`] around it.
    pub fn innermost(&self) -> &Error {
        match self {
            Error::Context { inner, .. } => inner.innermost(),
            e => e,
        }
    }

    /// A [`Error::BadFile`] for `path`.
    pub(crate) fn bad_file(path: impl Into<PathBuf>, problem: impl Into<String>) -> Error {
        Error::BadFile {
            path: path.into(),
            problem: problem.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A context the error already begins with is said once; another is put before it.
    #[test]
    fn a_context_is_said_once() {
        let bad = Error::bad_file("/in/p.dds", "truncated DDS");
        assert_eq!(
            bad.context("/in/p.dds").to_string(),
            "/in/p.dds: truncated DDS"
        );
        let e = Error::Invalid("no levels".into()).context("/in/p.dds");
        assert_eq!(e.to_string(), "/in/p.dds: no levels");
        // A context that is only a prefix of the path is not the path.
        let e = Error::bad_file("/in/p.dds", "truncated DDS").context("/in/p");
        assert_eq!(e.to_string(), "/in/p: /in/p.dds: truncated DDS");
    }
}
