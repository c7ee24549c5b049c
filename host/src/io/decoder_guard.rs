//! Third-party decoders turned total: a panic inside one (a malformed file
//! reaching an `unwrap` in the decoder crate, e.g. zune-jpeg 0.5.15's AVX2
//! IDCT) becomes the caller's typed error, and prints nothing.
//!
//! The panic hook is the process's, so it is wrapped once: while this
//! thread runs a guarded decoder the hook stays silent (the panic is
//! expected and reported as an error instead); otherwise, and on every
//! other thread, the previous hook runs as before. Needs `panic = "unwind"`
//! (every host profile; only the C libraries' `release-lib` aborts, and
//! they decode no images).

use std::any::Any;
use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    static GUARDED: Cell<bool> = const { Cell::new(false) };
}

static QUIET_HOOK: Once = Once::new();

/// `decode()`, or the message of the panic it raised.
pub(crate) fn guarded<T>(decode: impl FnOnce() -> T) -> Result<T, String> {
    QUIET_HOOK.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !GUARDED.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let was = GUARDED.with(|g| g.replace(true));
    let result = panic::catch_unwind(AssertUnwindSafe(decode));
    GUARDED.with(|g| g.set(was));
    result.map_err(|payload| panic_message(payload.as_ref()))
}

/// The message a caught panic carried (`panic!`'s text), for a report.
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string())
}

#[cfg(test)]
mod tests {
    use super::guarded;

    #[test]
    fn a_panic_becomes_its_message_and_the_guard_is_lifted() {
        assert_eq!(guarded(|| 7), Ok(7));
        let err = guarded(|| -> u8 { panic!("bad {}", "data") }).unwrap_err();
        assert_eq!(err, "bad data");
        let err = guarded(|| -> u8 { std::panic::panic_any(3u8) }).unwrap_err();
        assert_eq!(err, "a panic without a message");
        // Outside a guard, a panic still unwinds to its own catcher.
        assert!(std::panic::catch_unwind(|| panic!("unguarded")).is_err());
    }
}
