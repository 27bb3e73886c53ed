//! Error codes, the per-thread last-error message, and the guard every entry
//! point runs its body in (panics caught, callback aborts turned into codes).

use std::cell::{Cell, RefCell};
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The result of every call that can fail. `BM_OK` is 0; on any other value
/// the call has set the calling thread's last-error message
/// (`bm_last_error_message`, `bm_last_error`) and its out-parameters are
/// left untouched.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum bm_result {
    /// Success.
    BM_OK = 0,
    /// A required pointer argument was NULL.
    BM_ERR_NULL = 1,
    /// An argument is out of range: an unknown entity id, a buffer too
    /// short, a non-finite coordinate, an empty parameter interval, a handle
    /// of the wrong type.
    BM_ERR_RANGE = 2,
    /// The geometry or topology is inconsistent: a curve that does not start
    /// at its start vertex, an open loop, a loop edge off its plane.
    BM_ERR_GEOMETRY = 3,
    /// A host callback returned non-zero, or a value that is not finite (or
    /// a spacing that is not > 0). The message names the callback and the
    /// entity.
    BM_ERR_CALLBACK = 4,
    /// The spacing cannot be used: an expression that does not parse, a
    /// spacing that is not finite and > 0 where the engine asked, one that
    /// asks for too many bubbles, or a spacing plugin whose `init` refused
    /// its arguments or that failed (or answered NaN, ∞, d ≤ 0) while
    /// meshing (the message names the plugin, the point and the entity).
    BM_ERR_SPACING = 5,
    /// Meshing failed in the engine (triangulation); the message names the
    /// entity.
    BM_ERR_MESH = 6,
    /// A file could not be read (missing, unreadable) or written; the
    /// message names it.
    BM_ERR_IO = 7,
    /// The feature is not available: the engine cannot mesh what was asked
    /// (the message says what).
    BM_ERR_UNSUPPORTED = 8,
    /// The handle is in use by another call: another thread, or a callback
    /// that re-entered the library with the handle being meshed.
    BM_ERR_BUSY = 9,
    /// A string argument is not valid UTF-8.
    BM_ERR_UTF8 = 10,
    /// The progress callback asked to stop.
    BM_ERR_CANCELLED = 11,
    /// A bug: the library panicked. The message has the panic's text.
    BM_ERR_PANIC = 12,
    /// A file's content is not what it should be: a STEP file that is not
    /// STEP, truncated, a syntax error, an entity that cannot be converted
    /// (the message names the file, the entity `#id TYPE` and the reason);
    /// a spacing plugin that is not a loadable bubblemesh plugin; a
    /// malformed plugin configuration file; a state file that is not one,
    /// of another version of the format, truncated or corrupted.
    BM_ERR_FORMAT = 13,
    /// A state (`bm_state`) cannot re-mesh the model: it was saved from
    /// another model (fewer than half its entities match). The message
    /// says how many matched and why the first did not.
    BM_ERR_STATE = 14,
}

use bm_result::*;

impl bm_result {
    pub(crate) fn name(self) -> &'static str {
        match self {
            BM_OK => "BM_OK",
            BM_ERR_NULL => "BM_ERR_NULL",
            BM_ERR_RANGE => "BM_ERR_RANGE",
            BM_ERR_GEOMETRY => "BM_ERR_GEOMETRY",
            BM_ERR_CALLBACK => "BM_ERR_CALLBACK",
            BM_ERR_SPACING => "BM_ERR_SPACING",
            BM_ERR_MESH => "BM_ERR_MESH",
            BM_ERR_IO => "BM_ERR_IO",
            BM_ERR_UNSUPPORTED => "BM_ERR_UNSUPPORTED",
            BM_ERR_BUSY => "BM_ERR_BUSY",
            BM_ERR_UTF8 => "BM_ERR_UTF8",
            BM_ERR_CANCELLED => "BM_ERR_CANCELLED",
            BM_ERR_PANIC => "BM_ERR_PANIC",
            BM_ERR_FORMAT => "BM_ERR_FORMAT",
            BM_ERR_STATE => "BM_ERR_STATE",
        }
    }
}

/// An error on its way out of an entry point.
#[derive(Debug, Clone)]
pub(crate) struct Error {
    pub code: bm_result,
    pub msg: String,
}

impl Error {
    pub fn new(code: bm_result, msg: impl Into<String>) -> Self {
        Error {
            code,
            msg: msg.into(),
        }
    }
    pub fn null(arg: &str) -> Self {
        Error::new(BM_ERR_NULL, format!("argument '{arg}' is NULL"))
    }
    pub fn range(msg: impl Into<String>) -> Self {
        Error::new(BM_ERR_RANGE, msg)
    }
    pub fn geometry(msg: impl Into<String>) -> Self {
        Error::new(BM_ERR_GEOMETRY, msg)
    }
    pub fn callback(msg: impl Into<String>) -> Self {
        Error::new(BM_ERR_CALLBACK, msg)
    }
}

pub(crate) type Result<T> = std::result::Result<T, Error>;

/// The payload a geometry or spacing adapter unwinds with when a host
/// callback fails during meshing: the engine's traits return plain values,
/// so the adapter stops the engine at the first bad answer by unwinding
/// (without the panic hook, see [`abort_with`]) to the entry point's guard,
/// which turns it into an error code. Nothing of the engine's half-built
/// state survives the unwind.
pub(crate) struct Abort(pub Error);

/// Stops the running engine with `err` (see [`Abort`]).
pub(crate) fn abort_with(err: Error) -> ! {
    std::panic::resume_unwind(Box::new(Abort(err)))
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
    /// Depth of entry points on this thread that may call host callbacks
    /// (model validation and meshing). Adapters refuse to call the host
    /// outside them, which keeps the threading contract even if the engine
    /// one day evaluates geometry on worker threads.
    static CALLBACK_SCOPE: Cell<usize> = const { Cell::new(0) };
}

fn set_last_error(msg: &str) {
    let c = CString::new(msg.replace('\0', "\\0")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

fn clear_last_error() {
    LAST_ERROR.with(|e| {
        let mut e = e.borrow_mut();
        if !e.as_bytes().is_empty() {
            *e = CString::default();
        }
    });
}

/// The calling thread's last-error message (empty when the last call
/// succeeded), valid until the next call into the library on this thread.
pub(crate) fn last_error_ptr() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

pub(crate) fn last_error_bytes() -> Vec<u8> {
    LAST_ERROR.with(|e| e.borrow().as_bytes().to_vec())
}

/// Runs `f` with host callbacks allowed on this thread.
pub(crate) fn in_callback_scope<T>(f: impl FnOnce() -> T) -> T {
    struct Exit;
    impl Drop for Exit {
        fn drop(&mut self) {
            CALLBACK_SCOPE.with(|c| c.set(c.get() - 1));
        }
    }
    CALLBACK_SCOPE.with(|c| c.set(c.get() + 1));
    let _exit = Exit;
    f()
}

/// Whether host callbacks may be called on this thread now.
pub(crate) fn callbacks_allowed() -> bool {
    CALLBACK_SCOPE.with(|c| c.get() > 0)
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Turns a caught unwind into an error: an adapter's [`Abort`] keeps its
/// code and message, anything else is a library bug ([`BM_ERR_PANIC`]).
pub(crate) fn from_unwind(payload: Box<dyn std::any::Any + Send>) -> Error {
    match payload.downcast::<Abort>() {
        Ok(a) => a.0,
        Err(p) => Error::new(
            BM_ERR_PANIC,
            format!("internal error (panic): {}", panic_text(p.as_ref())),
        ),
    }
}

/// The body of every entry point that returns a [`bm_result`]: catches
/// panics, records the last error (prefixed with the function's name) or
/// clears it on success.
pub(crate) fn guard(func: &str, f: impl FnOnce() -> Result<()>) -> bm_result {
    let r = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(from_unwind(p)),
    };
    match r {
        Ok(()) => {
            clear_last_error();
            BM_OK
        }
        Err(e) => {
            set_last_error(&format!("{func}: {}", e.msg));
            e.code
        }
    }
}

/// The body of the `void` entry points (the `_free` functions): panics are
/// caught and recorded, nothing is returned.
pub(crate) fn guard_void(func: &str, f: impl FnOnce()) {
    if let Err(p) = catch_unwind(AssertUnwindSafe(f)) {
        set_last_error(&format!("{func}: {}", from_unwind(p).msg));
    }
}
