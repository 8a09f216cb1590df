//! Opening one file as DICOM: with or without the 128-byte preamble, with or without a file
//! meta group.
//!
//! In: a path and whether to stop before the pixel data. Out: [`Opened`]: a DICOM object with a
//! file meta table (synthesised when the file has none), or "not DICOM", or "DICOMDIR". Errors
//! are messages (the caller adds the path) saying what failed.
//!
//! How a file is recognised (the first bytes decide, nothing else):
//! - `DICM` at offset 128: standard Part 10 file;
//! - `DICM` at offset 0: magic code and file meta without preamble;
//! - a group 0002 tag at offset 0: file meta without preamble nor magic code (dicom-rs wants
//!   the magic code, so it is supplied in front of the bytes);
//! - a group 0008 tag at offset 0 (little or big endian): a bare data set without file meta, as
//!   old software and some test sets write. Its transfer syntax is guessed from the bytes (two
//!   uppercase letters after the tag = explicit VR) and the whole file is read; such files are
//!   rare, so reading their pixels during the header scan is acceptable;
//! - anything else is not DICOM (counted, never an error).

use std::fs::File;
use std::io::{BufReader, Cursor, Read};
use std::path::Path;

use dicom_dictionary_std::{tags, uids};
use dicom_encoding::TransferSyntaxIndex;
use dicom_object::file::ReadPreamble;
use dicom_object::meta::FileMetaTableBuilder;
use dicom_object::{FileDicomObject, InMemDicomObject, OpenFileOptions};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;

pub(crate) type Obj = FileDicomObject<InMemDicomObject>;

pub(crate) enum Opened {
    Dicom(Box<Obj>),
    NotDicom,
    DicomDir,
}

/// Opens `path`; with `header_only` the data set stops before PixelData.
pub(crate) fn open(path: &Path, header_only: bool) -> Result<Opened, String> {
    let mut head = [0u8; 132];
    let n = {
        let mut f = File::open(path).map_err(|e| format!("cannot open: {e}"))?;
        read_up_to(&mut f, &mut head).map_err(|e| format!("cannot read: {e}"))?
    };
    let head = &head[..n];
    let kind = if n >= 132 && &head[128..132] == b"DICM" {
        Kind::Preamble
    } else if n >= 8 && &head[0..4] == b"DICM" {
        Kind::MetaNoPreamble
    } else if n >= 8 && head[0..2] == [0x02, 0x00] {
        Kind::MetaNoMagic
    } else if n >= 8 && head[0..2] == [0x08, 0x00] {
        if is_vr(&head[4..6]) {
            Kind::Bare(uids::EXPLICIT_VR_LITTLE_ENDIAN)
        } else {
            Kind::Bare(uids::IMPLICIT_VR_LITTLE_ENDIAN)
        }
    } else if n >= 8 && head[0..2] == [0x00, 0x08] && is_vr(&head[4..6]) {
        // Retired, but old files still use it.
        Kind::Bare("1.2.840.10008.1.2.2")
    } else {
        return Ok(Opened::NotDicom);
    };

    let obj = match kind {
        Kind::Preamble | Kind::MetaNoPreamble => {
            let mut opts = OpenFileOptions::new().read_preamble(if kind == Kind::Preamble {
                ReadPreamble::Always
            } else {
                ReadPreamble::Never
            });
            if header_only {
                opts = opts.read_until(tags::PIXEL_DATA);
            }
            opts.open_file(path).map_err(|e| error_chain(&e))?
        }
        Kind::MetaNoMagic => {
            let mut opts = OpenFileOptions::new().read_preamble(ReadPreamble::Never);
            if header_only {
                opts = opts.read_until(tags::PIXEL_DATA);
            }
            let f = File::open(path).map_err(|e| format!("cannot open: {e}"))?;
            opts.from_reader(Cursor::new(b"DICM").chain(BufReader::new(f)))
                .map_err(|e| format!("file meta without magic code: {}", error_chain(&e)))?
        }
        Kind::Bare(ts_uid) => {
            let ts = TransferSyntaxRegistry
                .get(ts_uid)
                .ok_or_else(|| format!("transfer syntax {ts_uid} not registered"))?;
            let f = File::open(path).map_err(|e| format!("cannot open: {e}"))?;
            let data = InMemDicomObject::read_dataset_with_ts(BufReader::new(f), ts)
                .map_err(|e| format!("no file meta; read as {}: {}", ts.name(), error_chain(&e)))?;
            // with_meta copies SOP Class/Instance UIDs from the data set when present; the
            // placeholders only stand in when the data set lacks them.
            let meta = FileMetaTableBuilder::new()
                .transfer_syntax(ts_uid)
                .media_storage_sop_class_uid("1.2.840.10008.5.1.4.1.1.7")
                .media_storage_sop_instance_uid("2.25.0");
            data.with_meta(meta)
                .map_err(|e| format!("no file meta and cannot make one: {}", error_chain(&e)))?
        }
    };
    if obj.meta().media_storage_sop_class_uid() == uids::MEDIA_STORAGE_DIRECTORY_STORAGE {
        return Ok(Opened::DicomDir);
    }
    Ok(Opened::Dicom(Box::new(obj)))
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Preamble,
    MetaNoPreamble,
    MetaNoMagic,
    Bare(&'static str),
}

fn is_vr(b: &[u8]) -> bool {
    b.len() == 2 && b[0].is_ascii_uppercase() && b[1].is_ascii_uppercase()
}

fn read_up_to(f: &mut File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// The error and its sources on one line: dicom-rs errors put the useful detail in the chain.
pub(crate) fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        let m = c.to_string();
        if !s.contains(&m) {
            s.push_str(": ");
            s.push_str(&m);
        }
        cur = c.source();
    }
    s
}

/// Human name of a transfer syntax UID (the UID itself when unknown).
pub(crate) fn ts_name(uid: &str) -> String {
    match TransferSyntaxRegistry.get(uid) {
        Some(ts) => ts.name().to_string(),
        None => format!("unknown transfer syntax {}", uid.trim_end_matches('\0')),
    }
}
