//! The coordinator in this process: `seacover::server::serve` on a loopback
//! listener in a tokio task, its address, and a shutdown that checks how it
//! ended. For tests that drive the server with in-process clients (HTTP,
//! WebSocket, agents, the load client) rather than the binary.

use std::net::SocketAddr;
use std::time::Duration;

use seacover::server::{ServeConfig, ServeError, serve};
use tokio::net::TcpListener;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

/// How long [`Server::stop`] gives `serve` to return once cancelled.
const STOP_WITHIN: Duration = Duration::from_secs(5);

/// A running in-process coordinator.
pub(crate) struct Server {
    pub addr: SocketAddr,
    shutdown: CancellationToken,
    task: JoinHandle<Result<(), ServeError>>,
}

impl Server {
    /// Serves `config` on 127.0.0.1, port 0.
    pub(crate) async fn start(config: ServeConfig) -> Server {
        Server::start_on("127.0.0.1:0", config).await
    }

    /// Serves `config` on `bind` (e.g. a former address, to restart on the
    /// same port).
    pub(crate) async fn start_on(bind: &str, config: ServeConfig) -> Server {
        let listener = TcpListener::bind(bind).await.unwrap();
        let addr = listener.local_addr().unwrap();
        let shutdown = CancellationToken::new();
        let task = tokio::spawn(serve(listener, config, shutdown.clone()));
        Server {
            addr,
            shutdown,
            task,
        }
    }

    /// `http://addr`.
    pub(crate) fn base(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// `http://addr` followed by `path`.
    pub(crate) fn http(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    /// The vessel link's URL.
    pub(crate) fn ws(&self) -> String {
        format!("ws://{}/api/v1/vessels/link", self.addr)
    }

    /// The server's shutdown token (a clone), for clients that stop with it.
    pub(crate) fn shutdown(&self) -> CancellationToken {
        self.shutdown.clone()
    }

    /// Cancels; `serve` must return `Ok` within 5 s.
    pub(crate) async fn stop(self) {
        self.shutdown.cancel();
        tokio::time::timeout(STOP_WITHIN, self.task)
            .await
            .expect("serve returns within 5 s of the shutdown")
            .unwrap()
            .unwrap();
    }

    /// Cancels; `serve` must return `Ok`, however long it takes.
    pub(crate) async fn stop_unbounded(self) {
        self.shutdown.cancel();
        self.task.await.unwrap().unwrap();
    }

    /// Cancels and waits up to 5 s for `serve`, whatever it returns.
    pub(crate) async fn stop_ignoring_result(self) {
        self.shutdown.cancel();
        let _ = tokio::time::timeout(STOP_WITHIN, self.task).await;
    }
}
