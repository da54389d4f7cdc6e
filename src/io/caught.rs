//! A dependency's panic on bad input, caught and made an error. The
//! parquet crate panics on some corrupt files where it should return an
//! error (a bit flipped in a data page: "Num of bytes exceed
//! MAX_VLQ_BYTE_LEN (10)"; in the footer: "column start and length should
//! not be negative", "Decoder for dict should have been set"). Its readers
//! run inside [`caught`], so such a file is refused like any other file
//! that cannot be read, with the decoder's words and the file's name (the
//! caller's), and the process goes on: a study's other files are still
//! read and its finished results kept.

use std::cell::{Cell, RefCell};
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// Whether this thread is inside [`caught`].
    static CATCHING: Cell<bool> = const { Cell::new(false) };
    /// The message of the panic [`caught`] is catching.
    static MESSAGE: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// `f`'s result, or the message of a panic inside it. The panic is not
/// printed: the process's panic hook is given one step first (once), which
/// keeps the message of a panic inside `caught` on its thread and hands
/// every other panic, anywhere, to the hook that was there before.
pub fn caught<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let before = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if CATCHING.with(Cell::get) {
                MESSAGE.with(|m| *m.borrow_mut() = Some(text(info.payload())));
            } else {
                before(info);
            }
        }));
    });
    let outer = CATCHING.with(|c| c.replace(true));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    CATCHING.with(|c| c.set(outer));
    result.map_err(|payload| MESSAGE.with(|m| m.borrow_mut().take()).unwrap_or_else(|| text(&*payload)))
}

/// A panic's message: its text where it is text.
fn text(payload: &(dyn std::any::Any + Send)) -> String {
    match (payload.downcast_ref::<&str>(), payload.downcast_ref::<String>()) {
        (Some(s), _) => (*s).to_string(),
        (_, Some(s)) => s.clone(),
        _ => "a panic without a message".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::caught;

    #[test]
    fn a_panic_inside_is_its_message_and_a_value_passes() {
        assert_eq!(caught(|| 7), Ok(7));
        let v: Vec<u8> = Vec::new();
        assert_eq!(caught(|| v[3]), Err("index out of bounds: the len is 0 but the index is 3".to_string()));
        assert_eq!(caught(|| -> u8 { panic!("bad page {}", 4) }), Err("bad page 4".to_string()));
        // Nested: the inner panic is the inner call's; the outer goes on.
        assert_eq!(caught(|| caught(|| -> u8 { panic!("inner") }).map(|_| 0)), Ok(Err("inner".to_string())));
    }
}
