//! A store that stopped answering is not asked again for a few seconds.
//!
//! A read of a store that does not answer waits out the client's 10 s timeout. A mesh tile
//! reads its own record and its neighbours', in turn or two at a time, so in an outage it
//! waited 30 s, met the request limit and answered a bare 503 `unavailable` rather than
//! `storage_unavailable` in seconds, holding a blocking thread all the while (as did every
//! other request meanwhile). After a request that timed out or could not connect, every
//! request to the store fails at once for [`COOL_OFF`]; then one request is let through to
//! ask again while the others keep failing at once for another cool-off, and an answer puts
//! the store back in service. A store that answers, even with an error (a 500, a missing
//! object), is not cut off.

use std::ops::Range;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use async_trait::async_trait;
use bytes::Bytes;
use futures_util::stream::BoxStream;
use object_store::path::Path;
use object_store::{
    GetOptions, GetResult, ListResult, MultipartUpload, ObjectMeta, ObjectStore,
    PutMultipartOptions, PutOptions, PutPayload, PutResult, Result,
};

/// How long a store that did not answer is left alone.
pub const COOL_OFF: Duration = Duration::from_secs(5);

/// Why a request was not sent: the store did not answer one a moment ago.
#[derive(Debug, thiserror::Error)]
#[error(
    "the store did not answer a request {ago:.1} s ago; it is not asked again for another \
     {left:.1} s"
)]
pub struct NotAnswering {
    ago: f64,
    left: f64,
}

/// `inner`, cut off for [`COOL_OFF`] after a request it did not answer.
#[derive(Debug)]
pub struct Breaker {
    inner: Arc<dyn ObjectStore>,
    /// Since when requests fail at once: the last unanswered request, or the probe let
    /// through after a cool-off. `None` while the store answers.
    tripped: Mutex<Option<Instant>>,
    cool_off: Duration,
}

impl Breaker {
    pub fn new(inner: Arc<dyn ObjectStore>) -> Self {
        Self::with_cool_off(inner, COOL_OFF)
    }

    pub fn with_cool_off(inner: Arc<dyn ObjectStore>, cool_off: Duration) -> Self {
        Self {
            inner,
            tripped: Mutex::new(None),
            cool_off,
        }
    }

    /// An error when the store is cut off now. The first request after a cool-off goes
    /// through as the probe, and starts another cool-off for the rest: a store still hung
    /// would otherwise hold every request that came in meanwhile for its whole timeout.
    fn check(&self) -> Result<()> {
        let mut tripped = self.tripped.lock().unwrap_or_else(|e| e.into_inner());
        match tripped.map(|t| t.elapsed()) {
            Some(ago) if ago < self.cool_off => Err(object_store::Error::Generic {
                store: "zerotile",
                source: Box::new(NotAnswering {
                    ago: ago.as_secs_f64(),
                    left: (self.cool_off - ago).as_secs_f64(),
                }),
            }),
            Some(_) => {
                *tripped = Some(Instant::now());
                Ok(())
            }
            None => Ok(()),
        }
    }

    /// Notes how a request went: one the store did not answer cuts it off, any answer
    /// puts it back in service.
    fn note<T>(&self, r: Result<T>) -> Result<T> {
        let unanswered = r.as_ref().err().filter(|e| unanswered(e));
        let mut tripped = self.tripped.lock().unwrap_or_else(|e| e.into_inner());
        match (unanswered, tripped.is_some()) {
            (Some(e), was) => {
                if !was {
                    tracing::warn!(
                        "the data store did not answer ({e}); requests to it fail at once, \
                         one asking again every {} s",
                        self.cool_off.as_secs_f64()
                    );
                }
                *tripped = Some(Instant::now());
            }
            (None, true) => {
                tracing::info!("the data store answers again");
                *tripped = None;
            }
            (None, false) => {}
        }
        r
    }
}

/// Whether `e` is a request the store did not answer: a timeout or no connection. The
/// client's error is looked for by type (object_store's own kind of it is not in the chain:
/// its wrapper forwards past it).
fn unanswered(e: &object_store::Error) -> bool {
    let mut source: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(s) = source {
        if let Some(r) = s.downcast_ref::<reqwest::Error>() {
            return r.is_timeout() || r.is_connect();
        }
        source = s.source();
    }
    false
}

impl std::fmt::Display for Breaker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.inner.fmt(f)
    }
}

/// Reads and listings pass the breaker; writes, which the server never makes, go straight
/// through.
#[async_trait]
impl ObjectStore for Breaker {
    async fn get_opts(&self, location: &Path, options: GetOptions) -> Result<GetResult> {
        self.check()?;
        self.note(self.inner.get_opts(location, options).await)
    }

    /// The body too: a store can stop answering after the headers.
    async fn get_range(&self, location: &Path, range: Range<u64>) -> Result<Bytes> {
        self.check()?;
        self.note(self.inner.get_range(location, range).await)
    }

    async fn head(&self, location: &Path) -> Result<ObjectMeta> {
        self.check()?;
        self.note(self.inner.head(location).await)
    }

    async fn list_with_delimiter(&self, prefix: Option<&Path>) -> Result<ListResult> {
        self.check()?;
        self.note(self.inner.list_with_delimiter(prefix).await)
    }

    fn list(&self, prefix: Option<&Path>) -> BoxStream<'static, Result<ObjectMeta>> {
        self.inner.list(prefix)
    }

    async fn put_opts(
        &self,
        location: &Path,
        payload: PutPayload,
        opts: PutOptions,
    ) -> Result<PutResult> {
        self.inner.put_opts(location, payload, opts).await
    }

    async fn put_multipart_opts(
        &self,
        location: &Path,
        opts: PutMultipartOptions,
    ) -> Result<Box<dyn MultipartUpload>> {
        self.inner.put_multipart_opts(location, opts).await
    }

    async fn delete(&self, location: &Path) -> Result<()> {
        self.inner.delete(location).await
    }

    async fn copy(&self, from: &Path, to: &Path) -> Result<()> {
        self.inner.copy(from, to).await
    }

    async fn copy_if_not_exists(&self, from: &Path, to: &Path) -> Result<()> {
        self.inner.copy_if_not_exists(from, to).await
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use object_store::memory::InMemory;

    fn runtime() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
    }

    /// An HTTP store on a port nothing listens on: every request fails to connect.
    fn closed_port() -> Arc<dyn ObjectStore> {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let (store, _) =
            crate::serve::storage::connect(&format!("http://127.0.0.1:{port}/")).unwrap();
        store
    }

    fn cut_off(e: &object_store::Error) -> bool {
        std::error::Error::source(e).is_some_and(|s| s.is::<NotAnswering>())
    }

    /// After a request the store did not answer, the next fails without being sent, until
    /// the cool-off has passed; then the store is asked again.
    #[test]
    fn a_store_that_does_not_answer_is_cut_off_for_the_cool_off() {
        let rt = runtime();
        let store = Breaker::with_cool_off(closed_port(), Duration::from_millis(300));
        let at = Path::from("a.ztd");
        let first = rt.block_on(store.get_range(&at, 0..10)).unwrap_err();
        assert!(unanswered(&first), "{first}");
        assert!(!cut_off(&first));
        let second = rt.block_on(store.get_range(&at, 0..10)).unwrap_err();
        assert!(cut_off(&second), "{second}");
        assert!(second.to_string().contains("not asked again"), "{second}");
        let listing = rt.block_on(store.list_with_delimiter(None)).unwrap_err();
        assert!(cut_off(&listing), "{listing}");
        std::thread::sleep(Duration::from_millis(350));
        let later = rt.block_on(store.get_range(&at, 0..10)).unwrap_err();
        assert!(!cut_off(&later), "asked again after the cool-off: {later}");
        let after = rt.block_on(store.get_range(&at, 0..10)).unwrap_err();
        assert!(cut_off(&after), "one probe, then cut off again: {after}");
    }

    /// After a cool-off one request goes through as the probe; the others still fail at
    /// once while it is out, and its answer puts the store back in service.
    #[test]
    fn one_probe_after_the_cool_off_and_an_answer_ends_it() {
        let rt = runtime();
        let store = Breaker::with_cool_off(Arc::new(InMemory::new()), Duration::from_millis(200));
        *store.tripped.lock().unwrap() = Some(Instant::now() - Duration::from_secs(1));
        assert!(store.check().is_ok(), "the probe");
        assert!(store.check().is_err(), "the others while it is out");
        let at = Path::from("a.ztd");
        rt.block_on(store.put(&at, Bytes::from_static(b"0123456789").into()))
            .unwrap();
        // The probe's answer, an error or not, is an answer.
        store
            .note(rt.block_on(store.inner.get_range(&at, 0..3)))
            .unwrap();
        assert!(store.tripped.lock().unwrap().is_none());
        assert!(store.check().is_ok());
    }

    /// A store that answers, if only to say the object is not there, stays in service.
    #[test]
    fn an_answer_that_is_an_error_does_not_cut_the_store_off() {
        let rt = runtime();
        let store = Breaker::new(Arc::new(InMemory::new()));
        let at = Path::from("missing.ztd");
        for _ in 0..2 {
            let e = rt.block_on(store.get_range(&at, 0..10)).unwrap_err();
            assert!(matches!(e, object_store::Error::NotFound { .. }), "{e}");
        }
        rt.block_on(store.put(&at, Bytes::from_static(b"0123456789").into()))
            .unwrap();
        assert_eq!(
            rt.block_on(store.get_range(&at, 2..5)).unwrap(),
            Bytes::from_static(b"234")
        );
    }
}
