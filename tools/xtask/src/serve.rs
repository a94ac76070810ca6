//! A static file server for the viewer: `web/` at `/` and a scene package at `/scenes/<name>/`,
//! on 127.0.0.1 only. tower-http's `ServeDir` answers HTTP range requests (the viewer reads one
//! time step of `clouds.bin` at a time) and sets MIME types from extensions (`application/wasm`
//! for the wasm module, which browsers require for streaming compilation).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use anyhow::Context;
use axum::Router;
use axum::http::{HeaderValue, header};
use tower_http::services::ServeDir;
use tower_http::set_header::SetResponseHeaderLayer;

/// What to serve.
#[derive(Clone, Debug)]
pub struct Site {
    /// The page folder (`web/`, with the wasm package in `web/pkg/`).
    pub web_dir: PathBuf,
    /// Scene packages by URL name (`/scenes/<name>/`).
    pub scenes: Vec<(String, PathBuf)>,
}

fn router(site: &Site) -> Router {
    let mut app = Router::new();
    for (name, dir) in &site.scenes {
        app = app.nest_service(&format!("/scenes/{name}"), ServeDir::new(dir));
    }
    app.fallback_service(ServeDir::new(&site.web_dir))
        // Development server: always revalidate, so a rebuilt page or package is picked up.
        .layer(SetResponseHeaderLayer::overriding(header::CACHE_CONTROL, HeaderValue::from_static("no-cache")))
        // Pages of other origins may embed the viewer (`src/embed.js` is a module, fetched with CORS).
        .layer(SetResponseHeaderLayer::overriding(header::ACCESS_CONTROL_ALLOW_ORIGIN, HeaderValue::from_static("*")))
}

/// A server running on a background thread; dropped, it stops.
pub struct Running {
    /// Where it listens.
    pub addr: SocketAddr,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn bind(port: u16) -> anyhow::Result<std::net::TcpListener> {
    let listener = std::net::TcpListener::bind(("127.0.0.1", port)).with_context(|| format!("cannot listen on 127.0.0.1:{port}"))?;
    listener.set_nonblocking(true)?;
    Ok(listener)
}

/// Starts serving `site` on 127.0.0.1:`port` (0: any free port) in the background.
pub fn start(site: &Site, port: u16) -> anyhow::Result<Running> {
    check(site)?;
    let listener = bind(port)?;
    let addr = listener.local_addr()?;
    let app = router(site);
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let thread = std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().expect("tokio runtime");
        runtime.block_on(async move {
            let listener = tokio::net::TcpListener::from_std(listener).expect("listener");
            let _ = axum::serve(listener, app)
                .with_graceful_shutdown(async {
                    let _ = rx.await;
                })
                .await;
        });
    });
    Ok(Running { addr, shutdown: Some(tx), thread: Some(thread) })
}

/// Serves `site` on 127.0.0.1:`port` until Ctrl-C, trying the next ports when it is taken.
pub fn serve_forever(site: &Site, port: u16, on_ready: impl FnOnce(SocketAddr)) -> anyhow::Result<()> {
    check(site)?;
    let listener =
        (port..port.saturating_add(20)).find_map(|p| bind(p).ok()).with_context(|| format!("no free port in {port}..{}", port + 20))?;
    let addr = listener.local_addr()?;
    let app = router(site);
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    on_ready(addr);
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        axum::serve(listener, app)
            .with_graceful_shutdown(async {
                let _ = tokio::signal::ctrl_c().await;
            })
            .await
    })?;
    Ok(())
}

fn check(site: &Site) -> anyhow::Result<()> {
    let must_exist = |p: &Path, what: &str| {
        if p.is_dir() { Ok(()) } else { Err(anyhow::anyhow!("{what} {} does not exist", p.display())) }
    };
    must_exist(&site.web_dir, "page folder")?;
    for (_, dir) in &site.scenes {
        must_exist(dir, "scene package")?;
    }
    Ok(())
}
