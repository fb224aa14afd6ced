//! An error with its causes. Each layer's message says only what failed
//! there and hands its cause on as `source()`, never repeating the cause's
//! text; whoever shows an error (a log line, the binary) shows the chain:
//! `serving: Address already in use (os error 98)`.

use std::error::Error;
use std::fmt;

/// Displays an error and every cause after it, `: `-separated.
///
/// ```
/// let io = std::io::Error::other("disk full");
/// let e = seacover::recorder::reader::ReadError::Io { path: "a.mcap".into(), source: io };
/// assert_eq!(seacover::chain::Chain(&e).to_string(), "a.mcap: disk full");
/// ```
pub struct Chain<'a>(pub &'a (dyn Error + 'static));

impl fmt::Display for Chain<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)?;
        let mut cause = self.0.source();
        while let Some(c) = cause {
            write!(f, ": {c}")?;
            cause = c.source();
        }
        Ok(())
    }
}
