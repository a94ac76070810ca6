//! Where a scene package's bytes come from: an HTTP base URL (with range requests for the
//! clouds) or files the user dropped on the page. Works in a window and in a worker.

use std::collections::HashMap;

use js_sys::{Promise, Uint8Array};
use wasm_bindgen::prelude::*;
use wasm_bindgen_futures::JsFuture;

#[wasm_bindgen]
extern "C" {
    /// `globalThis.fetch`, present in windows and workers alike.
    #[wasm_bindgen(js_name = fetch)]
    fn global_fetch(request: &web_sys::Request) -> Promise;
}

/// A failed read, naming the file (URL or dropped path).
#[derive(Debug)]
pub struct ReadError(pub String);

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

fn js_message(value: &JsValue) -> String {
    value.as_string().or_else(|| js_sys::Error::from(value.clone()).message().as_string()).unwrap_or_else(|| format!("{value:?}"))
}

/// The bytes of a scene package.
#[derive(Debug)]
pub enum Source {
    /// A folder on a web server; `base` ends with `/`.
    Url {
        /// The folder URL.
        base: String,
    },
    /// Dropped or picked files, by their path relative to the package folder.
    Files(HashMap<String, web_sys::File>),
}

/// A read started (the request is in flight) but not yet awaited.
pub struct PendingRead {
    name: String,
    promise: Promise,
    range: Option<(u64, u64)>,
    limit: u64,
    is_fetch: bool,
}

impl Source {
    /// A URL source. `url` is the package folder or its `scene.json`.
    pub fn url(url: &str) -> Self {
        let mut base = url.trim().to_owned();
        if let Some(stripped) = base.strip_suffix(dynview_core::scene::manifest::MANIFEST_FILE) {
            base = stripped.to_owned();
        }
        if !base.ends_with('/') {
            base.push('/');
        }
        Self::Url { base }
    }

    /// A files source from `(path, file)` pairs; paths are relative to any folder, and the
    /// package root is the folder of the shallowest `scene.json`.
    pub fn files(entries: Vec<(String, web_sys::File)>) -> Result<Self, ReadError> {
        let manifest = dynview_core::scene::manifest::MANIFEST_FILE;
        let root = entries
            .iter()
            .map(|(p, _)| p.trim_start_matches('/'))
            .filter(|p| *p == manifest || p.ends_with(&format!("/{manifest}")))
            .min_by_key(|p| p.len())
            .map(|p| p[..p.len() - manifest.len()].to_owned())
            .ok_or_else(|| ReadError(format!("no {manifest} among the {} dropped files: drop the scene package folder", entries.len())))?;
        let files = entries
            .into_iter()
            .filter_map(|(p, f)| p.trim_start_matches('/').strip_prefix(root.as_str()).map(|rel| (rel.to_owned(), f)))
            .collect();
        Ok(Self::Files(files))
    }

    /// How the file `name` is called in messages.
    pub fn display_name(&self, name: &str) -> String {
        match self {
            Self::Url { base } => format!("{base}{name}"),
            Self::Files(_) => name.to_owned(),
        }
    }

    /// Starts reading `name` (the byte `range` `[start, end)` of it when given), refusing
    /// more than `limit` bytes.
    pub fn start(&self, name: &str, range: Option<(u64, u64)>, limit: u64) -> Result<PendingRead, ReadError> {
        let shown = self.display_name(name);
        let fail = |e: JsValue| ReadError(format!("{shown}: {}", js_message(&e)));
        match self {
            Self::Url { base } => {
                let init = web_sys::RequestInit::new();
                let request = web_sys::Request::new_with_str_and_init(&format!("{base}{name}"), &init).map_err(fail)?;
                if let Some((start, end)) = range {
                    request.headers().set("Range", &format!("bytes={start}-{}", end.saturating_sub(1))).map_err(fail)?;
                }
                Ok(PendingRead { name: shown, promise: global_fetch(&request), range, limit, is_fetch: true })
            }
            Self::Files(files) => {
                let file = files.get(name).ok_or_else(|| ReadError(format!("{shown}: missing from the dropped folder")))?;
                let size = file.size() as u64;
                let (start, end) = range.unwrap_or((0, size));
                if end > size || start > end {
                    return Err(ReadError(format!("{shown}: bytes {start}..{end} requested but the file has {size}")));
                }
                if end - start > limit {
                    return Err(ReadError(format!("{shown}: {} bytes exceeds the limit of {limit}", end - start)));
                }
                let blob = file.slice_with_f64_and_f64(start as f64, end as f64).map_err(fail)?;
                Ok(PendingRead { name: shown, promise: blob.array_buffer(), range, limit, is_fetch: false })
            }
        }
    }
}

impl PendingRead {
    /// Waits for the bytes.
    pub async fn bytes(self) -> Result<Vec<u8>, ReadError> {
        let name = self.name;
        let fail = |e: JsValue| ReadError(format!("{name}: {}", js_message(&e)));
        let value = JsFuture::from(self.promise).await.map_err(fail)?;
        if !self.is_fetch {
            return Ok(Uint8Array::new(&value).to_vec());
        }
        let response: web_sys::Response = value.dyn_into().map_err(fail)?;
        if !response.ok() {
            return Err(ReadError(format!("{name}: HTTP {} {}", response.status(), response.status_text())));
        }
        // Refuse an oversized body before reading it.
        let declared = response.headers().get("content-length").ok().flatten().and_then(|v| v.parse::<u64>().ok());
        let partial = response.status() == 206;
        let wanted = self.range.map(|(s, e)| e - s);
        if let Some(len) = declared
            && len > self.limit
            && !(partial && wanted.is_some_and(|w| w <= self.limit))
        {
            return Err(ReadError(format!("{name}: {len} bytes exceeds the limit of {}", self.limit)));
        }
        let buffer = JsFuture::from(response.array_buffer().map_err(fail)?).await.map_err(fail)?;
        let bytes = Uint8Array::new(&buffer).to_vec();
        match self.range {
            // A server without range support sends the whole file: cut the range out of it.
            Some((start, end)) if !partial => {
                let (start, end) = (start as usize, end as usize);
                bytes
                    .get(start..end)
                    .map(<[u8]>::to_vec)
                    .ok_or_else(|| ReadError(format!("{name}: bytes {start}..{end} requested but the file has {}", bytes.len())))
            }
            Some((start, end)) if bytes.len() as u64 != end - start => {
                Err(ReadError(format!("{name}: asked for {} bytes from {start}, got {}", end - start, bytes.len())))
            }
            _ => Ok(bytes),
        }
    }
}
