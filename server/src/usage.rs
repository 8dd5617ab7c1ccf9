//! Errors in the command line itself: a flag's value or a combination of flags that no
//! input could make right. They exit 2 like the argument parser's own, so a script can tell
//! "called wrongly" from "the file, the data or the machine failed" (exit 1) by the code
//! alone, whichever layer caught the mistake.

use std::fmt;

/// The exit code of a usage error, the argument parser's.
pub const EXIT: u8 = 2;

/// A usage error's message; see the module doc.
#[derive(Debug)]
pub struct Usage(String);

impl fmt::Display for Usage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// A usage error carrying `message`.
pub fn usage(message: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(Usage(message.into()))
}

/// Whether `e`, or anything it wraps, is a usage error.
pub fn is_usage(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| cause.is::<Usage>())
}

/// `bail!` for a usage error: returns `Err(usage(format!(…)))`.
#[macro_export]
macro_rules! bail_usage {
    ($($arg:tt)*) => {
        return Err($crate::usage::usage(format!($($arg)*)))
    };
}

#[cfg(test)]
mod tests {
    use anyhow::Context;

    use super::*;

    #[test]
    fn a_usage_error_is_known_under_context_and_others_are_not() {
        let e = usage("--faces must be > 0");
        assert!(is_usage(&e));
        assert_eq!(e.to_string(), "--faces must be > 0");
        let wrapped = Err::<(), _>(e).context("eval mesh").unwrap_err();
        assert!(is_usage(&wrapped));
        assert!(!is_usage(&anyhow::anyhow!("no such file")));
        let bailed = || -> anyhow::Result<()> { bail_usage!("--step {}: must be > 0", -1) };
        let e = bailed().unwrap_err();
        assert!(is_usage(&e));
        assert_eq!(e.to_string(), "--step -1: must be > 0");
    }
}
