//! Arrays the traversal reads at random, in memory backed by 2 MiB pages where the system
//! allows it (Linux transparent huge pages in `madvise` mode, the Debian default).
//!
//! Incoherent rays touch a few dozen nodes and packs spread over megabytes; with 4 KiB
//! pages nearly every visit also misses the TLB, and under virtualisation a miss is a
//! two-dimensional page walk. Embree allocates its BVH in huge pages for the same reason.
//! Arrays under 1 MiB, and every array on other systems, use the ordinary allocator.

use std::alloc::{Layout, alloc, dealloc};
use std::ops::Deref;
use std::ptr::NonNull;

const HUGE: usize = 2 << 20;
const HUGE_MIN: usize = 1 << 20;

/// An immutable array of `Copy` values, huge-page backed when large (see the module docs).
pub(crate) struct PageArray<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    /// The layout allocated, `None` when `len == 0` or `T` is zero-sized (nothing
    /// allocated; `ptr` is dangling).
    layout: Option<Layout>,
}

// SAFETY: `PageArray` owns its elements exactly like a `Box<[T]>` (no shared state, no
// interior mutability), so it is `Send`/`Sync` whenever `T` is.
unsafe impl<T: Copy + Send> Send for PageArray<T> {}
// SAFETY: as above; only `&[T]` is ever handed out.
unsafe impl<T: Copy + Sync> Sync for PageArray<T> {}

#[cfg(target_os = "linux")]
unsafe extern "C" {
    fn madvise(addr: *mut std::ffi::c_void, len: usize, advice: i32) -> i32;
}
#[cfg(target_os = "linux")]
const MADV_HUGEPAGE: i32 = 14;

impl<T: Copy> PageArray<T> {
    /// The array holding `v`'s elements.
    pub(crate) fn new(v: Vec<T>) -> Self {
        let bytes = std::mem::size_of_val(v.as_slice());
        if bytes < HUGE_MIN || !cfg!(target_os = "linux") {
            return Self::boxed(v);
        }
        let size = bytes.div_ceil(HUGE) * HUGE;
        let Ok(layout) = Layout::from_size_align(size, HUGE.max(std::mem::align_of::<T>())) else {
            return Self::boxed(v);
        };
        // SAFETY: `layout` has a non-zero size (`bytes >= HUGE_MIN`).
        let raw = unsafe { alloc(layout) };
        let Some(ptr) = NonNull::new(raw as *mut T) else {
            return Self::boxed(v);
        };
        #[cfg(target_os = "linux")]
        // SAFETY: `raw .. raw + size` is the block just allocated, 2 MiB aligned; madvise
        // only changes how the kernel backs it (a failure leaves ordinary pages).
        unsafe {
            madvise(raw as *mut std::ffi::c_void, size, MADV_HUGEPAGE);
        }
        // SAFETY: the block holds `size >= bytes` bytes aligned for `T`, does not overlap
        // `v`, and `T: Copy`, so a bitwise copy of `v.len()` elements initialises them.
        unsafe { std::ptr::copy_nonoverlapping(v.as_ptr(), ptr.as_ptr(), v.len()) };
        PageArray {
            ptr,
            len: v.len(),
            layout: Some(layout),
        }
    }

    /// An ordinary allocation (leaked from `v`'s boxed slice and freed with its layout).
    fn boxed(v: Vec<T>) -> Self {
        let len = v.len();
        let b = v.into_boxed_slice();
        let layout = (len > 0 && std::mem::size_of::<T>() > 0)
            .then(|| Layout::array::<T>(len).expect("the layout of an existing slice"));
        let ptr = NonNull::new(Box::into_raw(b) as *mut T).expect("Box pointers are non-null");
        PageArray { ptr, len, layout }
    }
}

impl<T: Copy> Deref for PageArray<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` points to `len` initialised elements owned by `self` (or is
        // dangling and well aligned with `len == 0` / zero-sized `T`, valid for a slice).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Drop for PageArray<T> {
    fn drop(&mut self) {
        if let Some(layout) = self.layout {
            // SAFETY: `ptr` was allocated with exactly `layout`, by `alloc` (huge) or by
            // the global allocator through `Box<[T]>` (`Layout::array::<T>(len)`, the
            // layout `Box` used), and is freed once. `T: Copy` has no destructor to run.
            unsafe { dealloc(self.ptr.as_ptr() as *mut u8, layout) };
        }
    }
}

impl<T: Copy> Clone for PageArray<T> {
    fn clone(&self) -> Self {
        PageArray::new(self.to_vec())
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for PageArray<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PageArray(len {})", self.len)
    }
}

impl<T: Copy> Default for PageArray<T> {
    fn default() -> Self {
        PageArray::new(Vec::new())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_large_and_empty_arrays_keep_their_contents() {
        for n in [0usize, 1, 1000, 300_000, 1_000_003] {
            let v: Vec<u64> = (0..n as u64).map(|i| i * 7 + 3).collect();
            let a = PageArray::new(v.clone());
            assert_eq!(&a[..], &v[..]);
            let b = a.clone();
            drop(a);
            assert_eq!(&b[..], &v[..]);
        }
    }
}
