//! Who may join the cluster: both ends of a connection prove that they hold the cluster token
//! without sending it. Each sends a fresh nonce ([`Challenge`]), then the HMAC-SHA256 under
//! the token of its own nonce followed by the peer's ([`Proof`]): a recorded proof is worth
//! nothing against a fresh nonce, and one end's proof is not the other's (the order differs).
//! Only after the peer's proof checks does a process say its hello (scene, settings, name),
//! and that hello carries the HMAC of itself under both nonces, so that nobody on the path can
//! swap it for another. Without a token the same exchange runs under an empty key: it proves
//! nothing, and a process that listens beyond loopback says so at start-up.
//!
//! [`Challenge`]: crate::messages::Challenge
//! [`Proof`]: crate::messages::Proof

use hmac::{Hmac, Mac};
use sha2::Sha256;

/// Bytes of a nonce and of a tag.
pub const NONCE_BYTES: usize = 32;
pub const TAG_BYTES: usize = 32;

/// The secret every process of a cluster holds. Never printed, never sent.
#[derive(Clone, PartialEq, Eq)]
pub struct Token(Vec<u8>);

impl Token {
    pub fn new(secret: impl Into<Vec<u8>>) -> Token {
        Token(secret.into())
    }
}

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("Token(..)")
    }
}

/// A fresh nonce from the operating system's generator.
pub fn nonce() -> [u8; NONCE_BYTES] {
    let mut n = [0; NONCE_BYTES];
    getrandom::fill(&mut n).expect("the operating system's random generator");
    n
}

/// What a message proves: a proof of the token, or a hello's integrity.
#[derive(Clone, Copy)]
pub enum Purpose {
    Proof,
    Hello,
}

/// The tag under `token` of `purpose`, the sender's nonce, the receiver's nonce and `bytes`.
pub fn tag(
    token: Option<&Token>,
    purpose: Purpose,
    sender: &[u8; NONCE_BYTES],
    receiver: &[u8; NONCE_BYTES],
    bytes: &[u8],
) -> [u8; TAG_BYTES] {
    mac(token, purpose, sender, receiver, bytes).finalize().into_bytes().into()
}

/// Whether `tag` is the sender's tag of `bytes` (compared in constant time).
pub fn verify(
    token: Option<&Token>,
    purpose: Purpose,
    sender: &[u8; NONCE_BYTES],
    receiver: &[u8; NONCE_BYTES],
    bytes: &[u8],
    tag: &[u8; TAG_BYTES],
) -> bool {
    mac(token, purpose, sender, receiver, bytes).verify_slice(tag).is_ok()
}

fn mac(token: Option<&Token>, purpose: Purpose, sender: &[u8; NONCE_BYTES], receiver: &[u8; NONCE_BYTES], bytes: &[u8]) -> Hmac<Sha256> {
    let key = token.map_or(&[][..], |t| &t.0);
    let mut m = Hmac::<Sha256>::new_from_slice(key).expect("HMAC takes a key of any length");
    m.update(match purpose {
        Purpose::Proof => b"osw proof\0",
        Purpose::Hello => b"osw hello\0",
    });
    m.update(sender);
    m.update(receiver);
    m.update(bytes);
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_proof_checks_only_under_its_token_its_nonces_in_its_order_and_its_purpose() {
        let (t, other) = (Token::new("right"), Token::new("wrong"));
        let (a, b) = (nonce(), nonce());
        assert_ne!(a, b, "nonces are fresh");
        let p = tag(Some(&t), Purpose::Proof, &a, &b, &[]);
        assert!(verify(Some(&t), Purpose::Proof, &a, &b, &[], &p));
        assert!(!verify(Some(&other), Purpose::Proof, &a, &b, &[], &p), "another token");
        assert!(!verify(None, Purpose::Proof, &a, &b, &[], &p), "no token");
        assert!(!verify(Some(&t), Purpose::Proof, &b, &a, &[], &p), "the peer's proof is not this one's");
        assert!(!verify(Some(&t), Purpose::Proof, &a, &nonce(), &[], &p), "a fresh nonce makes a recorded proof worthless");
        assert!(!verify(Some(&t), Purpose::Hello, &a, &b, &[], &p), "a proof is no hello tag");
        let h = tag(Some(&t), Purpose::Hello, &a, &b, b"hello");
        assert!(verify(Some(&t), Purpose::Hello, &a, &b, b"hello", &h));
        assert!(!verify(Some(&t), Purpose::Hello, &a, &b, b"hellO", &h), "a changed hello");
    }

    #[test]
    fn a_token_is_never_printed() {
        assert_eq!(format!("{:?}", Token::new("s3cret")), "Token(..)");
    }
}
