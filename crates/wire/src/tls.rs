//! Mutual TLS for links that cross networks a user does not trust (rustls with the ring
//! provider). Every process of a cluster holds a certificate that the cluster's own CA signed,
//! for the one name [`CLUSTER_NAME`]: a peer is admitted when its certificate chains to that CA,
//! whatever address it connects from, and refused before any osw byte otherwise. `osw certs`
//! makes a cluster's CA and certificates.

use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer, ServerName};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The name every cluster certificate is made for, and that a process checks its peer's against.
pub const CLUSTER_NAME: &str = "osw-cluster";

/// What cannot be read or used of the TLS files; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    #[error("{}", path.display())]
    Pem {
        path: PathBuf,
        #[source]
        source: rustls::pki_types::pem::Error,
    },
    #[error("{}: no certificate in it", .0.display())]
    NoCertificate(PathBuf),
    #[error("TLS configuration")]
    Config(#[from] rustls::Error),
    #[error("the client verifier")]
    Verifier(#[from] rustls::server::VerifierBuilderError),
}

/// A process's TLS configurations, for the connections it accepts and those it makes.
#[derive(Clone)]
pub struct Tls {
    pub(crate) server: Arc<rustls::ServerConfig>,
    pub(crate) client: Arc<rustls::ClientConfig>,
}

impl std::fmt::Debug for Tls {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("Tls(..)")
    }
}

impl Tls {
    /// Reads a process's certificate `cert`, its key `key` and the cluster's CA certificate
    /// `ca` (PEM): both directions authenticate with the certificate and trust only
    /// certificates the CA signed.
    pub fn load(cert: &Path, key: &Path, ca: &Path) -> Result<Tls, TlsError> {
        let certs = certificates(cert)?;
        let key = PrivateKeyDer::from_pem_file(key).map_err(|source| TlsError::Pem { path: key.to_owned(), source })?;
        let mut roots = rustls::RootCertStore::empty();
        for ca in certificates(ca)? {
            roots.add(ca)?;
        }
        let roots = Arc::new(roots);
        // ring, not aws-lc-rs (rustls's default): it builds without cmake or a C toolchain's
        // extras on every host a cluster runs on. rustls marks it deprecated because ring has
        // no post-quantum key exchange; its classical X25519 and ECDHE are what osw relies on.
        #[allow(deprecated)]
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let verifier = rustls::server::WebPkiClientVerifier::builder_with_provider(Arc::clone(&roots), Arc::clone(&provider)).build()?;
        let server = rustls::ServerConfig::builder_with_provider(Arc::clone(&provider))
            .with_safe_default_protocol_versions()?
            .with_client_cert_verifier(verifier)
            .with_single_cert(certs.clone(), key.clone_key())?;
        let client = rustls::ClientConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()?
            .with_root_certificates(roots)
            .with_client_auth_cert(certs, key)?;
        Ok(Tls { server: Arc::new(server), client: Arc::new(client) })
    }

    pub(crate) fn server_name() -> ServerName<'static> {
        ServerName::try_from(CLUSTER_NAME).expect("a DNS name")
    }
}

fn certificates(path: &Path) -> Result<Vec<CertificateDer<'static>>, TlsError> {
    let pem = |source| TlsError::Pem { path: path.to_owned(), source };
    let certs = CertificateDer::pem_file_iter(path).map_err(pem)?.collect::<Result<Vec<_>, _>>().map_err(pem)?;
    if certs.is_empty() {
        return Err(TlsError::NoCertificate(path.to_owned()));
    }
    Ok(certs)
}
