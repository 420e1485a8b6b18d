//! Hive-style escaping of partition values and file names.

/// Escapes a partition value or file stem: letters, digits, `-`, `_`, `.` kept, everything else
/// (and a leading `.`) as `%XX` of its UTF-8 bytes.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for (i, b) in s.bytes().enumerate() {
        let keep = b.is_ascii_alphanumeric() || b == b'-' || b == b'_' || (b == b'.' && i > 0);
        if keep {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    if out.is_empty() {
        out.push_str("%00");
    }
    out
}
