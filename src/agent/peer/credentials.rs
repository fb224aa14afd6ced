//! A fleet's credentials (docs/peer.md, "Credentials"): a certificate
//! authority of the fleet's own and one certificate per member, for
//! Zenoh's mutual TLS over QUIC datagrams. `seacover fleet credentials`
//! makes them; every member starts with `--zenoh-config` on its own
//! directory's configuration. No cryptography of ours: the certificates
//! are rcgen's, the handshake, encryption and checks Zenoh's (rustls).
//!
//! Layout of a credentials directory:
//! - `ca.pem`, `ca.key`: the fleet's authority (its key stays ashore),
//!   and `fleet.txt`, the fleet's name;
//! - `members/<id>/`: what member `id` carries, and nothing else: the
//!   authority's certificate, its own certificate and key, and a Zenoh
//!   configuration that uses them (`zenoh.json5`).
//!
//! Invariants: keys are the operating system's randomness (rcgen with
//! ring), ECDSA P-256; key files are readable by their owner only (0600);
//! a member's certificate is valid for both ends of a link (server and
//! client) and names the member in its common name; every link a member
//! opens or accepts is mutual TLS to the fleet's authority, on QUIC
//! datagrams (listening) or TLS over TCP (`tls/`, dialled): the
//! configuration allows no other protocol, so a member never talks in
//! the clear. A configuration names its files by absolute path (what any
//! Zenoh program reads); seacover also finds them next to the
//! configuration when the directory was copied elsewhere (`session`).

use std::io::Write;
use std::path::{Path, PathBuf};

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};

/// A member's Zenoh configuration, in its directory.
pub const CONFIG: &str = "zenoh.json5";
/// The members' directories, in the credentials directory.
pub const MEMBERS: &str = "members";
/// The files of a member's directory that a configuration names (Zenoh's
/// keys under `transport/link/tls`, and the file each names).
pub const FILES: [(&str, &str); 5] = [
    ("root_ca_certificate", CA_PEM),
    ("listen_certificate", MEMBER_PEM),
    ("listen_private_key", MEMBER_KEY),
    ("connect_certificate", MEMBER_PEM),
    ("connect_private_key", MEMBER_KEY),
];
/// How long a member's certificate is valid unless told [days].
pub const DEFAULT_DAYS: u32 = 365;
/// How long the authority's certificate is valid [days]: longer than any
/// member's, so that renewing members never needs a new authority.
const AUTHORITY_DAYS: i64 = 20 * 365;
/// A certificate is valid from this long before it was made, for boats
/// whose clocks run behind the shore's.
const BACKDATE: time::Duration = time::Duration::days(1);

/// The fleet's name, for the authority a revocation makes.
const FLEET: &str = "fleet.txt";
const CA_PEM: &str = "ca.pem";
const CA_KEY: &str = "ca.key";
const MEMBER_PEM: &str = "member.pem";
const MEMBER_KEY: &str = "member.key";

/// Why credentials could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CredentialsError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0} holds a fleet's authority already: add members with --add")]
    Exists(PathBuf),
    #[error("{0} holds no fleet authority: make one with --members")]
    NoAuthority(PathBuf),
    #[error("a member id must match [A-Za-z0-9_.-]{{1,64}}: {0:?}")]
    Id(String),
    #[error("{0} is a member already: --renew issues every member a new certificate")]
    Member(String),
    #[error("{0} is not a member")]
    NotMember(String),
    #[error("the certificate")]
    Certificate(#[from] rcgen::Error),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CredentialsError + '_ {
    move |source| CredentialsError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Makes fleet `fleet`'s authority in `dir` (created when missing; an
/// existing authority is never overwritten) and issues `members` a
/// certificate each, valid `days`. Returns their configurations.
pub fn create(
    dir: &Path,
    fleet: &str,
    members: &[String],
    days: u32,
) -> Result<Vec<PathBuf>, CredentialsError> {
    check_ids(members)?;
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let dir = &dir.canonicalize().map_err(io(dir))?;
    if dir.join(CA_KEY).exists() {
        return Err(CredentialsError::Exists(dir.to_path_buf()));
    }
    new_authority(dir, fleet)?;
    add(dir, members, days)
}

/// Issues `members`, none of them a member yet, a certificate each from
/// the authority in `dir`. Returns their configurations.
pub fn add(dir: &Path, members: &[String], days: u32) -> Result<Vec<PathBuf>, CredentialsError> {
    check_ids(members)?;
    let issuer = authority(dir)?;
    if let Some(id) = members.iter().find(|id| member_dir(dir, id).exists()) {
        return Err(CredentialsError::Member(id.clone()));
    }
    members
        .iter()
        .map(|id| issue(dir, id, &issuer, days))
        .collect()
}

/// Issues every member a new certificate from the same authority, valid
/// `days` (before the old ones expire: nothing else changes, and members
/// with old and new certificates keep talking). Returns the
/// configurations.
pub fn renew(dir: &Path, days: u32) -> Result<Vec<PathBuf>, CredentialsError> {
    let issuer = authority(dir)?;
    members_of(dir)?
        .iter()
        .map(|id| issue(dir, id, &issuer, days))
        .collect()
}

/// Revokes `id`: a new authority for fleet `fleet` replaces the old one,
/// `id`'s directory is removed and every other member is issued a
/// certificate from the new authority, valid `days`. Zenoh checks no
/// revocation list, so only a new authority shuts a member out; until a
/// member has its new directory it cannot talk to those that have theirs.
/// Returns the other members' configurations.
pub fn revoke(dir: &Path, id: &str, days: u32) -> Result<Vec<PathBuf>, CredentialsError> {
    authority(dir)?;
    let name = dir.join(FLEET);
    let fleet = std::fs::read_to_string(&name).map_err(io(&name))?;
    let gone = member_dir(dir, id);
    if !gone.exists() {
        return Err(CredentialsError::NotMember(id.to_string()));
    }
    std::fs::remove_dir_all(&gone).map_err(io(&gone))?;
    for name in [CA_KEY, CA_PEM] {
        let path = dir.join(name);
        std::fs::remove_file(&path).map_err(io(&path))?;
    }
    new_authority(dir, fleet.trim())?;
    renew(dir, days)
}

/// The ids of the members in `dir`, sorted.
pub fn members_of(dir: &Path) -> Result<Vec<String>, CredentialsError> {
    let path = dir.join(MEMBERS);
    let mut ids = Vec::new();
    if path.exists() {
        for entry in std::fs::read_dir(&path).map_err(io(&path))? {
            let entry = entry.map_err(io(&path))?;
            if entry.path().join(MEMBER_PEM).exists() {
                ids.push(entry.file_name().to_string_lossy().into_owned());
            }
        }
    }
    ids.sort();
    Ok(ids)
}

fn check_ids(ids: &[String]) -> Result<(), CredentialsError> {
    match ids
        .iter()
        .find(|id| !crate::mission::scenario::valid_id(id))
    {
        Some(id) => Err(CredentialsError::Id(id.clone())),
        None => Ok(()),
    }
}

fn member_dir(dir: &Path, id: &str) -> PathBuf {
    dir.join(MEMBERS).join(id)
}

fn validity(params: &mut CertificateParams, days: i64) {
    let now = time::OffsetDateTime::now_utc();
    params.not_before = now - BACKDATE;
    params.not_after = now + time::Duration::days(days);
}

fn new_authority(dir: &Path, fleet: &str) -> Result<(), CredentialsError> {
    public_file(&dir.join(FLEET), &format!("{fleet}\n"))?;
    let key = KeyPair::generate()?;
    let mut params = CertificateParams::default();
    params
        .distinguished_name
        .push(DnType::CommonName, format!("seacover fleet {fleet}"));
    params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    validity(&mut params, AUTHORITY_DAYS);
    let cert = params.self_signed(&key)?;
    private_file(&dir.join(CA_KEY), &key.serialize_pem())?;
    public_file(&dir.join(CA_PEM), &cert.pem())
}

fn authority(dir: &Path) -> Result<Issuer<'static, KeyPair>, CredentialsError> {
    let (pem, key) = (dir.join(CA_PEM), dir.join(CA_KEY));
    if !key.exists() {
        return Err(CredentialsError::NoAuthority(dir.to_path_buf()));
    }
    let key = KeyPair::from_pem(&std::fs::read_to_string(&key).map_err(io(&key))?)?;
    let pem = std::fs::read_to_string(&pem).map_err(io(&pem))?;
    Ok(Issuer::from_ca_cert_pem(&pem, key)?)
}

/// Writes member `id`'s directory (replacing what was there) with a new
/// key and certificate; returns its configuration's path.
fn issue(
    dir: &Path,
    id: &str,
    issuer: &Issuer<'_, KeyPair>,
    days: u32,
) -> Result<PathBuf, CredentialsError> {
    let key = KeyPair::generate()?;
    let mut params = CertificateParams::new(vec![id.to_string()])?;
    params.distinguished_name.push(DnType::CommonName, id);
    params.is_ca = IsCa::ExplicitNoCa;
    params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    params.extended_key_usages = vec![
        ExtendedKeyUsagePurpose::ServerAuth,
        ExtendedKeyUsagePurpose::ClientAuth,
    ];
    validity(&mut params, i64::from(days));
    let cert = params.signed_by(&key, issuer)?;
    let home = member_dir(dir, id);
    if home.exists() {
        std::fs::remove_dir_all(&home).map_err(io(&home))?;
    }
    std::fs::create_dir_all(&home).map_err(io(&home))?;
    let ca = std::fs::read_to_string(dir.join(CA_PEM)).map_err(io(dir))?;
    public_file(&home.join(CA_PEM), &ca)?;
    public_file(&home.join(MEMBER_PEM), &cert.pem())?;
    private_file(&home.join(MEMBER_KEY), &key.serialize_pem())?;
    let config = home.join(CONFIG);
    private_file(&config, &member_config(&home, id))?;
    Ok(config)
}

/// Member `id`'s Zenoh configuration, its files in `home`.
fn member_config(home: &Path, id: &str) -> String {
    let tls: String = FILES
        .iter()
        .map(|(key, file)| format!("        {key}: {:?},\n", home.join(file).to_string_lossy()))
        .collect();
    format!(
        "// Zenoh configuration of seacover fleet member {id:?}: mutual TLS to\n\
         // the fleet's authority, listening on QUIC datagrams (docs/peer.md,\n\
         // \"Credentials\"). Start the member with --zenoh-config on this file;\n\
         // seacover also finds the files next to it when the directory is\n\
         // copied elsewhere.\n\
         {{\n  listen: {{ endpoints: [\"quic/0.0.0.0:0?rel=0\"] }},\n  transport: {{\n    link: {{\n\
         \x20     protocols: [\"quic\", \"tls\"],\n      tls: {{\n{tls}\
         \x20       enable_mtls: true,\n        verify_name_on_connect: false,\n\
         \x20       close_link_on_expiration: true,\n      }},\n    }},\n  }},\n}}\n"
    )
}

fn public_file(path: &Path, text: &str) -> Result<(), CredentialsError> {
    std::fs::write(path, text).map_err(io(path))
}

fn private_file(path: &Path, text: &str) -> Result<(), CredentialsError> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .map_err(io(path))?;
    f.write_all(text.as_bytes()).map_err(io(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_fleet_gets_an_authority_and_a_directory_per_member() {
        let dir = tempfile::tempdir().unwrap();
        let configs = create(dir.path(), "bay", &ids(&["usv-1", "shore"]), 30).unwrap();
        assert_eq!(configs.len(), 2);
        assert_eq!(members_of(dir.path()).unwrap(), ids(&["shore", "usv-1"]));
        let mode = |p: &Path| {
            use std::os::unix::fs::PermissionsExt;
            std::fs::metadata(p).unwrap().permissions().mode() & 0o777
        };
        assert_eq!(mode(&dir.path().join(CA_KEY)), 0o600);
        let home = dir.path().join(MEMBERS).join("usv-1");
        assert_eq!(mode(&home.join(MEMBER_KEY)), 0o600);
        assert!(
            !home.join(CA_KEY).exists(),
            "the authority's key stays ashore"
        );
        let config = zenoh::Config::from_file(&configs[1]).unwrap();
        let json = config.get_json("transport/link/tls/enable_mtls").unwrap();
        assert_eq!(json, "true");
        let cert = std::fs::read_to_string(home.join(MEMBER_PEM)).unwrap();
        assert!(cert.starts_with("-----BEGIN CERTIFICATE-----"));
        // A second fleet in the same place would orphan the first's members.
        let again = create(dir.path(), "bay", &ids(&["usv-2"]), 30).unwrap_err();
        assert!(matches!(again, CredentialsError::Exists(_)), "{again}");
        assert!(matches!(
            add(dir.path(), &ids(&["usv-1"]), 30).unwrap_err(),
            CredentialsError::Member(_)
        ));
        assert!(matches!(
            add(dir.path(), &ids(&["bad id"]), 30).unwrap_err(),
            CredentialsError::Id(_)
        ));
    }

    #[test]
    fn revoking_a_member_makes_a_new_authority_for_the_others() {
        let dir = tempfile::tempdir().unwrap();
        create(dir.path(), "bay", &ids(&["a", "b", "c"]), 30).unwrap();
        let old = std::fs::read_to_string(dir.path().join(CA_PEM)).unwrap();
        let configs = revoke(dir.path(), "b", 30).unwrap();
        assert_eq!(configs.len(), 2);
        assert_eq!(members_of(dir.path()).unwrap(), ids(&["a", "c"]));
        let new = std::fs::read_to_string(dir.path().join(CA_PEM)).unwrap();
        assert_ne!(old, new);
        let carried = dir.path().join(MEMBERS).join("a").join(CA_PEM);
        assert_eq!(std::fs::read_to_string(carried).unwrap(), new);
        assert!(matches!(
            revoke(dir.path(), "b", 30).unwrap_err(),
            CredentialsError::NotMember(_)
        ));
    }
}
