//! Files as a master names them: `fmuResourceLocation` is a `file:` URI (FMI 2.0, section
//! 2.1.5; RFC 8089), `moduleParameterFile` a path or a `file:` URI. Windows forms are
//! understood on Windows: `file:///C:/Program%20Files/x`, `file://localhost/C:/x`,
//! `file:/C:/x`, `file://server/share/x` (UNC), and paths with drive letters and
//! backslashes, which the operating system takes as they are.

use std::path::{Path, PathBuf};

use percent_encoding::percent_decode_str;

/// The rules of the operating system the FMU runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Os {
    /// Drive letters (`/C:/x` → `C:\x`), UNC hosts (`//server/share` → `\\server\share`).
    Windows,
    /// One root: a host other than `localhost` is not a local file.
    Unix,
}

impl Os {
    /// The operating system this binary was built for.
    pub const HERE: Os = if cfg!(windows) { Os::Windows } else { Os::Unix };
}

/// Why a `file:` URI names no local file; each carries the URI.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum UriError {
    /// Not a `file:` URI at all.
    NotFileUri(String),
    /// Its percent-encoded path is not UTF-8.
    PathNotUtf8(String),
    /// (Unix) No absolute path.
    NoAbsolutePath(String),
    /// (Unix) It names another host.
    RemoteHost { uri: String, host: String },
    /// (Windows) Neither a drive letter nor a UNC host.
    NoDriveOrHost(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::NotFileUri(uri) => write!(f, "\"{uri}\" is not a file: URI"),
            UriError::PathNotUtf8(uri) => {
                write!(f, "\"{uri}\": the percent-encoded path is not UTF-8")
            }
            UriError::NoAbsolutePath(uri) => write!(f, "\"{uri}\" has no absolute path"),
            UriError::RemoteHost { uri, host } => {
                write!(f, "\"{uri}\" names host \"{host}\", not a local file")
            }
            UriError::NoDriveOrHost(uri) => write!(f, "\"{uri}\" has no drive letter or UNC host"),
        }
    }
}

impl std::error::Error for UriError {}

/// Whether `text` is a `file:` URI (the scheme is case-insensitive).
pub fn is_file_uri(text: &str) -> bool {
    text.get(..5)
        .is_some_and(|scheme| scheme.eq_ignore_ascii_case("file:"))
}

/// The local path of the `file:` URI `uri`, percent-decoded, following `os`'s rules.
pub fn file_uri_to_path(uri: &str, os: Os) -> Result<PathBuf, UriError> {
    if !is_file_uri(uri) {
        return Err(UriError::NotFileUri(uri.into()));
    }
    let rest = &uri[5..];
    // file://host/path or file:///path (empty host); file:/path has no authority at all.
    let (host, path) = match rest.strip_prefix("//") {
        Some(authority_and_path) => match authority_and_path.find('/') {
            Some(slash) => authority_and_path.split_at(slash),
            None => (authority_and_path, ""),
        },
        None => ("", rest),
    };
    let path = percent_decode_str(path)
        .decode_utf8()
        .map_err(|_| UriError::PathNotUtf8(uri.into()))?;
    let local_host = host.is_empty() || host.eq_ignore_ascii_case("localhost");
    match os {
        Os::Unix if local_host && path.starts_with('/') => Ok(PathBuf::from(path.into_owned())),
        Os::Unix if local_host => Err(UriError::NoAbsolutePath(uri.into())),
        Os::Unix => Err(UriError::RemoteHost {
            uri: uri.into(),
            host: host.into(),
        }),
        Os::Windows => {
            let backslashed = path.replace('/', "\\");
            if !local_host {
                return Ok(PathBuf::from(format!("\\\\{host}{backslashed}")));
            }
            // "/C:/x" or "/C|/x" (an old form) is the drive path "C:\x".
            let bytes = backslashed.as_bytes();
            if bytes.len() >= 3
                && bytes[0] == b'\\'
                && bytes[1].is_ascii_alphabetic()
                && matches!(bytes[2], b':' | b'|')
            {
                Ok(PathBuf::from(format!(
                    "{}:{}",
                    bytes[1] as char,
                    &backslashed[3..]
                )))
            } else {
                Err(UriError::NoDriveOrHost(uri.into()))
            }
        }
    }
}

/// The file that `moduleParameterFile = value` names: a `file:` URI is decoded; a relative
/// path is looked up in the FMU's resources folder (`resources`, from fmuResourceLocation)
/// first and then in the working directory; an absolute path is taken as it is.
pub fn locate(value: &str, resources: Option<&Path>, os: Os) -> Result<PathBuf, UriError> {
    if is_file_uri(value) {
        return file_uri_to_path(value, os);
    }
    let path = PathBuf::from(value);
    if let Some(resources) = resources.filter(|_| path.is_relative()) {
        let in_resources = resources.join(&path);
        if in_resources.is_file() {
            return Ok(in_resources);
        }
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn windows(uri: &str) -> Result<String, String> {
        file_uri_to_path(uri, Os::Windows)
            .map(|p| p.to_string_lossy().into_owned())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn windows_uris_with_and_without_a_host_give_drive_paths() {
        for uri in [
            "file:///C:/Program%20Files/AEM/resources",
            "file://localhost/C:/Program%20Files/AEM/resources",
            "FILE://LOCALHOST/C:/Program Files/AEM/resources",
            "file:/C:/Program%20Files/AEM/resources",
            "file:///C|/Program%20Files/AEM/resources",
        ] {
            assert_eq!(
                windows(uri).as_deref(),
                Ok("C:\\Program Files\\AEM\\resources"),
                "{uri}"
            );
        }
        assert_eq!(
            windows("file://server/share/a%C3%A9.json").as_deref(),
            Ok("\\\\server\\share\\aé.json")
        );
        assert!(windows("file:///no-drive/x")
            .unwrap_err()
            .contains("no drive letter"));
    }

    #[test]
    fn unix_uris_are_local_absolute_paths() {
        let unix = |uri: &str| file_uri_to_path(uri, Os::Unix).map_err(|e| e.to_string());
        assert_eq!(
            unix("file:///tmp/a%20b/resources"),
            Ok(PathBuf::from("/tmp/a b/resources"))
        );
        assert_eq!(unix("file://localhost/tmp/x"), Ok(PathBuf::from("/tmp/x")));
        assert_eq!(unix("file:/tmp/x"), Ok(PathBuf::from("/tmp/x")));
        assert!(unix("file://server/tmp/x")
            .unwrap_err()
            .contains("not a local file"));
        assert!(unix("file:relative")
            .unwrap_err()
            .contains("no absolute path"));
        assert!(unix("file:///%FF").unwrap_err().contains("not UTF-8"));
        assert!(unix("/tmp/x").unwrap_err().contains("not a file: URI"));
    }

    #[test]
    fn a_relative_parameter_file_is_found_in_the_resources_first() {
        let resources =
            std::env::temp_dir().join(format!("aem-file-location-{}", std::process::id()));
        std::fs::create_dir_all(&resources).unwrap();
        std::fs::write(resources.join("modules.json"), "{}").unwrap();
        assert_eq!(
            locate("modules.json", Some(&resources), Os::HERE),
            Ok(resources.join("modules.json"))
        );
        assert_eq!(
            locate("other.json", Some(&resources), Os::HERE),
            Ok(PathBuf::from("other.json"))
        );
        assert_eq!(
            locate("modules.json", None, Os::HERE),
            Ok(PathBuf::from("modules.json"))
        );
        let absolute = resources.join("modules.json");
        assert_eq!(
            locate(
                absolute.to_str().unwrap(),
                Some(Path::new("/elsewhere")),
                Os::HERE
            ),
            Ok(absolute.clone())
        );
        std::fs::remove_dir_all(&resources).unwrap();
    }
}
