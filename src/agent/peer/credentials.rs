//! A fleet's credentials: Zenoh's own user/password authentication, no
//! cryptography of ours. `seacover fleet credentials DIR` writes a random
//! password, the dictionary of accepted users, and a Zenoh JSON5
//! configuration that uses both; every member is started with
//! `--zenoh-config DIR/zenoh.json5`. A process without them cannot open a
//! Zenoh session with any member, so it neither hears the fleet nor is
//! heard by it.
//!
//! Invariants: the password is 32 bytes of the operating system's random
//! source, hex-encoded; the files are readable by their owner only
//! (0600); the configuration names the dictionary by its absolute path
//! (what any Zenoh program reads), and seacover also finds it next to the
//! configuration when the directory was copied elsewhere (`session`).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The configuration file's name in the credentials directory.
pub const CONFIG: &str = "zenoh.json5";
/// The dictionary's name in the credentials directory.
pub const DICTIONARY: &str = "users.txt";

/// Writes the credentials of fleet `fleet` into `dir` (created when
/// missing; existing credentials are not overwritten). Returns the
/// configuration's path.
pub fn write(dir: &Path, fleet: &str) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let dir = &dir.canonicalize()?;
    let config = dir.join(CONFIG);
    if config.exists() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            format!(
                "{} exists: remove it to make new credentials",
                config.display()
            ),
        ));
    }
    let mut bytes = [0u8; 32];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    let password: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    let user = format!("seacover-{fleet}");
    let dictionary = dir.join(DICTIONARY);
    private_file(&dictionary, &format!("{user}:{password}\n"))?;
    let dictionary = dictionary.to_string_lossy();
    let json5 = format!(
        "// Zenoh configuration of the seacover fleet {fleet:?}: user/password\n\
         // authentication (Zenoh's usrpwd). Start every member with\n\
         // --zenoh-config {CONFIG}; seacover also finds the dictionary\n\
         // next to this file when the directory is copied elsewhere.\n\
         {{\n  transport: {{\n    auth: {{\n      usrpwd: {{\n        user: {user:?},\n        password: {password:?},\n        dictionary_file: {dictionary:?},\n      }},\n    }},\n  }},\n}}\n"
    );
    private_file(&config, &json5)?;
    Ok(config)
}

fn private_file(path: &Path, text: &str) -> std::io::Result<()> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)?;
    f.write_all(text.as_bytes())
}
