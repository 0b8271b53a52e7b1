//! Transfer functions as a request names them: a colormap name, a JSON
//! file (a path ending in `.json`), or JSON text (Python's dict); read
//! once here with the same errors for every front end.

use super::{Message, Opt, PolicyError, Refusal};
use crate::gpu::render::{Transfer, TransferSource};

/// The transfer function a request names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TransferChoice {
    /// A colormap name or a path ending in `.json`.
    Named(String),
    /// The JSON text of a transfer function.
    Json(String),
}

impl Default for TransferChoice {
    fn default() -> Self {
        TransferChoice::Named("viridis".into())
    }
}

impl TransferChoice {
    /// The file this choice reads, if it names one.
    pub fn file(&self) -> Option<&str> {
        match self {
            TransferChoice::Named(s) => match TransferSource::parse(s) {
                Ok(TransferSource::File(_)) => Some(s),
                _ => None,
            },
            TransferChoice::Json(_) => None,
        }
    }
}

/// A transfer function read: the function itself (`None` for a colormap)
/// and the colormap's name (empty for a function).
#[derive(Clone, Debug, PartialEq)]
pub struct ReadTransfer {
    /// The control points (`None`: the colormap over the shown range).
    pub transfer: Option<Transfer>,
    /// The colormap's name when `transfer` is `None`.
    pub colormap: String,
}

/// Reads `choice`: a colormap name as is, a `.json` file read and parsed,
/// JSON text parsed; anything else refused naming both possibilities (and
/// that a file of that name exists, when one does).
pub fn read(choice: &TransferChoice) -> Result<ReadTransfer, PolicyError> {
    let function = |t| ReadTransfer {
        transfer: Some(t),
        colormap: String::new(),
    };
    let arg = match choice {
        TransferChoice::Json(text) => {
            let t = Transfer::from_json(text)
                .map_err(|e| PolicyError::invalid(Message::new().text(e.to_string())))?;
            return Ok(function(t));
        }
        TransferChoice::Named(s) => s,
    };
    let path = match TransferSource::parse(arg) {
        Ok(TransferSource::Colormap(name)) => {
            return Ok(ReadTransfer {
                transfer: None,
                colormap: name,
            });
        }
        Ok(TransferSource::File(path)) => path,
        Err(e) => {
            let hint = match std::path::Path::new(arg).is_file() {
                true => {
                    " (a file of that name exists: a transfer-function file must be named *.json)"
                }
                false => "",
            };
            return Err(PolicyError::invalid(
                Message::new()
                    .opt(Opt::Transfer)
                    .text(format!(": {e}{hint}")),
            ));
        }
    };
    let bytes = std::fs::read(&path).map_err(|source| PolicyError {
        context: Message::new(),
        refusal: Refusal::Read {
            what: format!("the transfer function {path}"),
            source,
        },
    })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        PolicyError::invalid(Message::new().text(format!(
            "{path} is not UTF-8 text (byte {})",
            e.utf8_error().valid_up_to()
        )))
    })?;
    let t = Transfer::from_json(&text)
        .map_err(|e| PolicyError::invalid(Message::new().text(format!("in {path}: {e}"))))?;
    Ok(function(t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_files_and_json_are_read_alike() {
        let r = read(&TransferChoice::Named("magma".into())).unwrap();
        assert_eq!((r.transfer, r.colormap.as_str()), (None, "magma"));
        let e = read(&TransferChoice::Named("plasma".into())).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("transfer: 'plasma' is neither a colormap name"),
            "{e}"
        );
        let e = read(&TransferChoice::Named("/nonexistent/tf.json".into())).unwrap_err();
        assert!(matches!(e.refusal, Refusal::Read { .. }), "{e}");
        assert!(
            e.to_string()
                .starts_with("cannot read the transfer function /nonexistent/tf.json"),
            "{e}"
        );
        let json = r#"{"points":[{"value":0,"color":[1,0,0],"opacity":1}]}"#;
        let r = read(&TransferChoice::Json(json.into())).unwrap();
        assert_eq!(r.transfer.unwrap().points.len(), 1);
        let e = read(&TransferChoice::Json("{".into())).unwrap_err();
        assert!(e.to_string().contains("transfer function JSON"), "{e}");
    }
}
