//! `osw certs`: a cluster's own certificate authority and a certificate for each of its
//! processes, for mutual TLS on every link (osw_wire::tls). Every certificate is made for the
//! one name the processes check (`osw-cluster`), so that a peer is admitted for being signed by
//! this CA, whatever address it connects from. The CA's key signs nothing else: keep it off the
//! cluster's hosts once the certificates are made.

use anyhow::Context;
use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The processes to make certificates for, each NAME.pem and NAME.key.
    #[arg(long, value_delimiter = ',', default_value = "node-a,node-b,display")]
    names: Vec<String>,
    /// Output directory: ca.pem and ca.key (the cluster's CA), and each process's certificate
    /// and key. Keys are written readable by their owner only.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(bad) = a.names.iter().find(|n| n.is_empty() || n.contains(['/', '\\']) || *n == "ca") {
        anyhow::bail!("--names: {bad:?} is not a file name (and \"ca\" is the CA's)");
    }
    std::fs::create_dir_all(&a.out).with_context(|| a.out.display().to_string())?;
    let mut ca = CertificateParams::new(Vec::<String>::new())?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca.distinguished_name.push(DnType::CommonName, "osw cluster CA");
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    let ca_key = KeyPair::generate()?;
    let ca_cert = ca.self_signed(&ca_key)?;
    write(&a.out.join("ca.pem"), &ca_cert.pem(), false)?;
    write(&a.out.join("ca.key"), &ca_key.serialize_pem(), true)?;
    let issuer = Issuer::new(ca, ca_key);
    for name in &a.names {
        let mut p = CertificateParams::new(vec![osw_wire::tls::CLUSTER_NAME.to_owned()])?;
        p.distinguished_name.push(DnType::CommonName, name.as_str());
        p.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth, ExtendedKeyUsagePurpose::ClientAuth];
        let key = KeyPair::generate()?;
        let cert = p.signed_by(&key, &issuer)?;
        write(&a.out.join(format!("{name}.pem")), &cert.pem(), false)?;
        write(&a.out.join(format!("{name}.key")), &key.serialize_pem(), true)?;
    }
    out!("certs: the cluster's CA and {} certificates → {}", a.names.len(), a.out.display());
    Ok(())
}

/// Writes `text` to `path`; a key readable by its owner only.
fn write(path: &Path, text: &str, secret: bool) -> anyhow::Result<()> {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create(true).truncate(true);
    #[cfg(unix)]
    if secret {
        std::os::unix::fs::OpenOptionsExt::mode(&mut o, 0o600);
    }
    let mut f = o.open(path).with_context(|| path.display().to_string())?;
    std::io::Write::write_all(&mut f, text.as_bytes()).with_context(|| path.display().to_string())
}
