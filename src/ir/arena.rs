//! `Arena<T>` and `Handle<T>`, after naga's `arena/`: values live in a `Vec`,
//! spans in a parallel side table, and a handle is a 32-bit index whose
//! `Option` costs nothing (`NonZeroU32` storing index + 1).

use std::fmt;
use std::hash::Hash;
use std::marker::PhantomData;
use std::num::NonZeroU32;

use super::persist::{Layered, LayeredMap};
use crate::span::Span;

/// A typed index into an [`Arena`]. Debug prints `[3]`.
pub struct Handle<T> {
    index_plus_one: NonZeroU32,
    marker: PhantomData<fn() -> T>,
}

impl<T> Handle<T> {
    /// The handle of the arena entry at `index`.
    #[allow(clippy::expect_used)] // 2³² nodes exhaust memory first; index + 1 ≥ 1 is nonzero
    pub fn new(index: usize) -> Handle<T> {
        let n = u32::try_from(index + 1).expect("arena larger than u32::MAX - 1");
        Handle { index_plus_one: NonZeroU32::new(n).expect("index + 1 is nonzero"), marker: PhantomData }
    }

    /// The position of the entry in its arena.
    pub fn index(self) -> usize {
        self.index_plus_one.get() as usize - 1
    }
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Handle<T> {}
impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index_plus_one == other.index_plus_one
    }
}
impl<T> Eq for Handle<T> {}
impl<T> PartialOrd for Handle<T> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Handle<T> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.index_plus_one.cmp(&other.index_plus_one)
    }
}
impl<T> Hash for Handle<T> {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.index_plus_one.hash(state)
    }
}
impl<T> fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}]", self.index())
    }
}
impl<T> fmt::Display for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "%{}", self.index())
    }
}

/// Values of one kind, appended in order; spans in a side table. Both are
/// [`Layered`]: a clone shares what was frozen.
#[derive(Clone, Debug)]
pub struct Arena<T: Clone> {
    data: Layered<T>,
    spans: Layered<Span>,
}

impl<T: Clone> Default for Arena<T> {
    fn default() -> Self {
        Arena { data: Layered::default(), spans: Layered::default() }
    }
}

impl<T: Clone> Arena<T> {
    /// Adds `value` at the end, with the source span it came from.
    pub fn append(&mut self, value: T, span: Span) -> Handle<T> {
        let h = Handle::new(self.data.len());
        self.data.push(value);
        self.spans.push(span);
        h
    }

    /// How many entries the arena holds.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the arena holds no entry.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The entry of `h`, if it is in this arena.
    pub fn get(&self, h: Handle<T>) -> Option<&T> {
        self.data.get(h.index())
    }

    /// The source span of entry `h`.
    pub fn span(&self, h: Handle<T>) -> Span {
        self.spans.get(h.index()).copied().unwrap_or(Span::DETACHED)
    }

    /// The entries with their handles, in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = (Handle<T>, &T)> {
        self.data.iter().enumerate().map(|(i, v)| (Handle::new(i), v))
    }
}

impl<T: Clone> std::ops::Index<Handle<T>> for Arena<T> {
    type Output = T;
    fn index(&self, h: Handle<T>) -> &T {
        &self.data[h.index()]
    }
}

/// An arena that interns its values (hash-consing): appending a value equal
/// to one already present returns the existing handle, and the span of the
/// first occurrence is kept (as naga's `UniqueArena`).
#[derive(Clone, Debug)]
pub struct UniqueArena<T: Eq + Hash + Clone> {
    arena: Arena<T>,
    map: LayeredMap<T, Handle<T>>,
}

impl<T: Eq + Hash + Clone> Default for UniqueArena<T> {
    fn default() -> Self {
        UniqueArena { arena: Arena::default(), map: LayeredMap::default() }
    }
}

impl<T: Eq + Hash + Clone> UniqueArena<T> {
    /// The handle of `value`, and whether it was new.
    pub fn insert(&mut self, value: T, span: Span) -> (Handle<T>, bool) {
        if let Some(&h) = self.map.get(&value) {
            return (h, false);
        }
        let h = self.arena.append(value.clone(), span);
        self.map.insert_new(value, h);
        (h, true)
    }

    /// The handle of an entry equal to `value`, if there is one.
    pub fn find(&self, value: &T) -> Option<Handle<T>> {
        self.map.get(value).copied()
    }

    /// The entries, as a plain arena.
    pub fn arena(&self) -> &Arena<T> {
        &self.arena
    }

    /// How many distinct entries the arena holds.
    pub fn len(&self) -> usize {
        self.arena.len()
    }

    /// Whether the arena holds no entry.
    pub fn is_empty(&self) -> bool {
        self.arena.is_empty()
    }
}

impl<T: Eq + Hash + Clone> std::ops::Index<Handle<T>> for UniqueArena<T> {
    type Output = T;
    fn index(&self, h: Handle<T>) -> &T {
        &self.arena[h]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_handle_is_four_bytes() {
        assert_eq!(std::mem::size_of::<Option<Handle<u8>>>(), 4);
    }

    #[test]
    fn unique_arena_interns() {
        let mut a = UniqueArena::default();
        let (h1, new1) = a.insert("x".to_string(), Span::new(0, 1));
        let (h2, new2) = a.insert("x".to_string(), Span::new(5, 6));
        assert!(new1 && !new2);
        assert_eq!(h1, h2);
        assert_eq!(a.arena().span(h1), Span::new(0, 1));
        assert_eq!(format!("{h1:?}"), "[0]");
    }
}
