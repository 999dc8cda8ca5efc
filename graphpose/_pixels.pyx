"""A decoded 8-bit grey image's pixels as a NumPy array without copying them.

``np.asarray`` of a Pillow image copies its pixels through ``Image.tobytes``, in chunks joined
into one bytes object and then into the array: at 12 MP some 10-20 ms and a second 12 MB, more
than the board search takes there. Pillow (11.2 and later) also exports an image through the
Arrow C data interface (``Image.__arrow_c_array__``: a schema and an array capsule whose buffer
is the image's own memory, held alive by the array's release callback). :func:`grey_view`
takes that export for a single-band 8-bit image (Arrow format ``"C"``, one data buffer of
``height x width`` bytes, rows contiguous) and returns an object whose buffer is those bytes,
``height x width`` row-major, read-only (as ``np.asarray`` of an image is); it releases the export when the last view of it goes.
Anything else (another format, nulls, an offset) is declined with None, and the caller copies.

The two structs are the Arrow C data interface's, declared here as its specification gives them
(https://arrow.apache.org/docs/format/CDataInterface.html): a stable ABI, not a library.
"""

from cpython.buffer cimport PyBUF_WRITABLE
from cpython.pycapsule cimport PyCapsule_GetPointer
from libc.string cimport strcmp


cdef extern from *:
    """
    struct GPArrowSchema {
      const char* format; const char* name; const char* metadata; long long flags; long long n_children;
      struct GPArrowSchema** children; struct GPArrowSchema* dictionary;
      void (*release)(struct GPArrowSchema*); void* private_data;
    };
    struct GPArrowArray {
      long long length; long long null_count; long long offset; long long n_buffers; long long n_children;
      const void** buffers; struct GPArrowArray** children; struct GPArrowArray* dictionary;
      void (*release)(struct GPArrowArray*); void* private_data;
    };
    """
    struct GPArrowSchema:
        const char* format
    struct GPArrowArray:
        long long length
        long long null_count
        long long offset
        long long n_buffers
        long long n_children
        const void** buffers
        void (*release)(GPArrowArray*) noexcept nogil


cdef class GreyPixels:
    """The pixels of an exported Arrow array of ``height x width`` bytes, as a buffer (2-D,
    unsigned bytes, row-major, read-only); owns the array and releases it when collected."""

    cdef GPArrowArray array
    cdef Py_ssize_t shape[2]
    cdef Py_ssize_t strides[2]

    def __dealloc__(self):
        if self.array.release != NULL:
            self.array.release(&self.array)

    def __getbuffer__(self, Py_buffer *buffer, int flags):
        if flags & PyBUF_WRITABLE:
            raise BufferError("the decoded pixels are read-only")
        buffer.buf = <void*>self.array.buffers[1]
        buffer.obj = self
        buffer.len = self.shape[0] * self.shape[1]
        buffer.readonly = 1
        buffer.itemsize = 1
        buffer.format = "B"
        buffer.ndim = 2
        buffer.shape = self.shape
        buffer.strides = self.strides
        buffer.suboffsets = NULL
        buffer.internal = NULL

    def __releasebuffer__(self, Py_buffer *buffer):
        pass


def grey_view(schema, array, Py_ssize_t height, Py_ssize_t width):
    """A :class:`GreyPixels` over the Arrow export (``schema``, ``array`` capsules, as
    ``Image.__arrow_c_array__`` returns them) of an 8-bit grey image of ``height x width``
    pixels, or None when the export is not one (then it is left to its capsules to release).
    The array is moved into the result (its capsule no longer releases it)."""
    cdef GPArrowSchema* s = <GPArrowSchema*>PyCapsule_GetPointer(schema, "arrow_schema")
    cdef GPArrowArray* a = <GPArrowArray*>PyCapsule_GetPointer(array, "arrow_array")
    if (a.release == NULL or s.format == NULL or strcmp(s.format, "C") != 0 or a.n_buffers != 2
            or a.offset != 0 or a.null_count != 0 or a.n_children != 0 or height < 0 or width < 0
            or a.length != height * width or a.buffers == NULL or (a.buffers[1] == NULL and a.length > 0)):
        return None
    cdef GreyPixels view = GreyPixels.__new__(GreyPixels)
    view.array = a[0]
    a.release = NULL  # moved (the C data interface's move): the view releases it now
    view.shape[0], view.shape[1] = height, width
    view.strides[0], view.strides[1] = width, 1
    return view

