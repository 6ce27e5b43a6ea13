//! Persistent, append-only tables, so that copying a [`super::Module`] costs
//! a few reference counts instead of the whole program (the
//! combiner generator copies the module once per candidate pass, which made
//! planning quadratic in the number of statements).
//!
//! [`Layered`] is an append-only vector kept as a few shared, frozen layers
//! plus a short private tail: a clone shares every layer and copies at most
//! [`TAIL`] elements. A layer is extended in place while nobody else holds
//! it; otherwise a new layer starts, and layers are merged as a binary
//! counter merges its digits, so there are O(log n) of them and each element
//! is copied O(log n) times at most. [`Shared`] is a copy-on-write table for
//! the resource lists (textures, vectors, statements), which the planner
//! changes rarely and the generator never.

use rustc_hash::FxHashMap as HashMap;
use std::hash::Hash;
use std::ops::{Deref, DerefMut, Index};
use std::sync::Arc;

/// Elements kept in the private tail before it is frozen into a layer.
pub const TAIL: usize = 32;

/// An append-only vector whose clone shares everything but a short tail.
#[derive(Clone, Debug)]
pub struct Layered<T: Clone> {
    /// Frozen layers, oldest first, and the index of each one's first element.
    layers: Vec<(usize, Arc<Vec<T>>)>,
    tail: Vec<T>,
    /// The index of `tail[0]`.
    tail_start: usize,
}

impl<T: Clone> Default for Layered<T> {
    fn default() -> Self {
        Layered { layers: Vec::new(), tail: Vec::new(), tail_start: 0 }
    }
}

impl<T: Clone> Layered<T> {
    /// How many elements, over every layer and the tail.
    pub fn len(&self) -> usize {
        self.tail_start + self.tail.len()
    }

    /// Whether there is no element.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Element `i`, in whichever layer holds it.
    pub fn get(&self, i: usize) -> Option<&T> {
        if i >= self.tail_start {
            return self.tail.get(i - self.tail_start);
        }
        // The newest layer first: recent nodes are read most.
        let k = match self.layers.last() {
            Some((start, _)) if i >= *start => self.layers.len() - 1,
            _ => self.layers.partition_point(|(start, _)| *start <= i) - 1,
        };
        let (start, layer) = &self.layers[k];
        layer.get(i - start)
    }

    /// Appends `value`; returns its index.
    pub fn push(&mut self, value: T) -> usize {
        self.tail.push(value);
        if self.tail.len() >= TAIL {
            self.freeze();
        }
        self.len() - 1
    }

    /// Moves the tail into the layers: into the newest layer where nobody
    /// shares it, else as a new layer, merging equal-sized neighbours.
    fn freeze(&mut self) {
        let tail = std::mem::take(&mut self.tail);
        let n = tail.len();
        match self.layers.last_mut().and_then(|(_, l)| Arc::get_mut(l)) {
            Some(last) => last.extend(tail),
            None => self.layers.push((self.tail_start, Arc::new(tail))),
        }
        self.tail_start += n;
        while let [.., (start, a), (_, b)] = self.layers.as_slice() {
            if b.len() < a.len() {
                break;
            }
            let start = *start;
            let mut merged = Vec::with_capacity(a.len() + b.len());
            merged.extend(a.iter().cloned());
            merged.extend(b.iter().cloned());
            self.layers.truncate(self.layers.len() - 2);
            self.layers.push((start, Arc::new(merged)));
        }
    }

    /// The elements in order, layers first, then the tail.
    pub fn iter(&self) -> impl Iterator<Item = &T> + '_ {
        self.layers.iter().flat_map(|(_, l)| l.iter()).chain(self.tail.iter())
    }
}

impl<T: Clone> Index<usize> for Layered<T> {
    type Output = T;
    fn index(&self, i: usize) -> &T {
        match self.get(i) {
            Some(v) => v,
            None => panic!("index {i} out of range for a table of {}", self.len()),
        }
    }
}

/// A copy-on-write value: clones share it until one of them changes it.
#[derive(Debug, Default, PartialEq)]
pub struct Shared<T>(Arc<T>);

impl<T> Clone for Shared<T> {
    fn clone(&self) -> Self {
        Shared(Arc::clone(&self.0))
    }
}

impl<T> Deref for Shared<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T: Clone> DerefMut for Shared<T> {
    fn deref_mut(&mut self) -> &mut T {
        Arc::make_mut(&mut self.0)
    }
}

impl<T> From<T> for Shared<T> {
    fn from(value: T) -> Self {
        Shared(Arc::new(value))
    }
}

impl<T: Clone> Shared<Vec<T>> {
    /// The vector, copied only if another clone still shares it.
    pub fn into_inner(self) -> Vec<T> {
        Arc::unwrap_or_clone(self.0)
    }
}

impl<T: Clone> IntoIterator for Shared<Vec<T>> {
    type Item = T;
    type IntoIter = std::vec::IntoIter<T>;
    fn into_iter(self) -> Self::IntoIter {
        self.into_inner().into_iter()
    }
}

impl<'a, T> IntoIterator for &'a Shared<Vec<T>> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl<'a, T: Clone> IntoIterator for &'a mut Shared<Vec<T>> {
    type Item = &'a mut T;
    type IntoIter = std::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        Arc::make_mut(&mut self.0).iter_mut()
    }
}

impl<T> FromIterator<T> for Shared<Vec<T>> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        Shared(Arc::new(iter.into_iter().collect()))
    }
}

/// A hash map that only grows, in layers as [`Layered`]: a clone shares
/// every frozen layer and copies a tail of at most [`TAIL`] entries.
#[derive(Clone, Debug)]
pub struct LayeredMap<K, V> {
    layers: Vec<Arc<HashMap<K, V>>>,
    tail: HashMap<K, V>,
}

impl<K, V> Default for LayeredMap<K, V> {
    fn default() -> Self {
        LayeredMap { layers: Vec::new(), tail: HashMap::default() }
    }
}

impl<K: Eq + Hash + Clone, V: Clone> LayeredMap<K, V> {
    /// The value of `key`: the tail's, else the newest layer's that has it.
    pub fn get(&self, key: &K) -> Option<&V> {
        self.tail.get(key).or_else(|| self.layers.iter().rev().find_map(|l| l.get(key)))
    }

    /// Inserts a key not present.
    pub fn insert_new(&mut self, key: K, value: V) {
        self.tail.insert(key, value);
        if self.tail.len() >= TAIL {
            let tail = std::mem::take(&mut self.tail);
            match self.layers.last_mut().and_then(Arc::get_mut) {
                Some(last) => last.extend(tail),
                None => self.layers.push(Arc::new(tail)),
            }
            while let [.., a, b] = self.layers.as_slice() {
                if b.len() < a.len() {
                    break;
                }
                let mut merged = HashMap::with_capacity_and_hasher(a.len() + b.len(), Default::default());
                merged.extend(a.iter().map(|(k, v)| (k.clone(), v.clone())));
                merged.extend(b.iter().map(|(k, v)| (k.clone(), v.clone())));
                self.layers.truncate(self.layers.len() - 2);
                self.layers.push(Arc::new(merged));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clones see what was there when they were made, whatever either side
    /// appends afterwards, across tails, in-place layers and merges.
    #[test]
    fn clones_are_independent_snapshots() {
        let mut a = Layered::default();
        let mut snapshots = Vec::new();
        for i in 0..2000usize {
            a.push(i);
            if i % 37 == 0 {
                snapshots.push((i + 1, a.clone()));
            }
        }
        for (n, mut s) in snapshots {
            assert_eq!(s.len(), n);
            s.push(usize::MAX);
            assert!(s.iter().take(n).copied().eq(0..n));
            assert_eq!(s[n], usize::MAX);
            assert!((0..n).all(|i| s[i] == i));
        }
        assert!((0..2000).all(|i| a[i] == i));
        assert!(a.layers.len() <= 12, "{} layers", a.layers.len());
    }

    #[test]
    fn shared_copies_on_write() {
        let mut a: Shared<Vec<u8>> = vec![1, 2].into();
        let b = a.clone();
        a.push(3);
        assert_eq!((a.len(), b.len()), (3, 2));
    }
}
