//! CDR as ROS 2 puts it on the wire and rosbag2 stores it: a 4-byte encapsulation header
//! (`00 01 00 00` for little-endian CDR) and the serialized message.

use serde::{de::DeserializeOwned, Serialize};

/// Encapsulation header of little-endian plain CDR.
pub(crate) const HEADER_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why bytes are not a message.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CdrError {
    /// Fewer than 4 bytes, or an encapsulation this crate does not read.
    #[error("not plain CDR: encapsulation header {0:02x?}")]
    Encapsulation(Vec<u8>),
    /// The payload does not decode as the message.
    #[error("CDR payload does not decode: {0}")]
    Payload(String),
}

/// A message as encapsulated little-endian CDR.
pub fn encode<T: Serialize>(message: &T) -> Result<Vec<u8>, CdrError> {
    let mut out = HEADER_LE.to_vec();
    cdr_encoding::to_writer::<T, byteorder::LittleEndian, _>(&mut out, message)
        .map_err(|e| CdrError::Payload(e.to_string()))?;
    Ok(out)
}

/// A message from encapsulated CDR, little- or big-endian.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    let (header, payload) = bytes
        .split_at_checked(4)
        .ok_or_else(|| CdrError::Encapsulation(bytes.to_vec()))?;
    let result = match header[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(payload),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(payload),
        _ => return Err(CdrError::Encapsulation(header.to_vec())),
    };
    result
        .map(|(m, _)| m)
        .map_err(|e| CdrError::Payload(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{GraspCandidate, GripRecommendation};

    #[test]
    fn round_trip() {
        let c = crate::msg::paper_cases().swap_remove(0);
        let bytes = encode(&c).expect("encodes");
        assert_eq!(&bytes[..4], &HEADER_LE);
        assert_eq!(decode::<GraspCandidate>(&bytes).expect("decodes"), c);
        let a = crate::answer::answer(&c, &crate::solver::Settings::default());
        let back: GripRecommendation = decode(&encode(&a).expect("encodes")).expect("decodes");
        assert_eq!(back, a);
        assert!(decode::<GraspCandidate>(&[1, 2]).is_err());
    }
}
