"""PNG's row filters undone, compiled: the one loop of the 8-bit grey PNG reader
(:mod:`graphpose._png`) that Python makes slow.
"""


def png_unfilter_grey8(const unsigned char[::1] raw, unsigned char[:, ::1] out):
    """PNG's row filters undone for an 8-bit grey image (one byte a pixel): ``raw`` holds
    ``height`` rows of a filter-type byte and ``width`` filtered bytes (the inflated IDAT
    stream), ``out`` (height, width) gets the pixels. The five filters of the PNG
    specification (ISO/IEC 15948, section 9): None, Sub, Up, Average and Paeth, modulo 256,
    the row above the first and the byte left of each row's first being 0. Returns 0, or -1
    at a filter type the specification does not have (``out`` is then partly written)."""
    cdef Py_ssize_t h = out.shape[0], w = out.shape[1], i, j
    cdef const unsigned char *src
    cdef unsigned char *row
    cdef const unsigned char *up
    cdef int kind, a, b, c, p, pa, pb, pc
    cdef int bad = 0
    if raw.shape[0] != h * (w + 1):
        raise ValueError("the inflated data is not height x (width + 1) bytes")
    if h == 0 or w == 0:
        return 0
    with nogil:
        for i in range(h):
            src = &raw[i * (w + 1) + 1]
            kind = raw[i * (w + 1)]
            row = &out[i, 0]
            up = &out[i - 1, 0] if i > 0 else NULL
            if kind == 0 or (kind == 2 and up == NULL):
                for j in range(w):
                    row[j] = src[j]
            elif kind == 1 or (kind == 4 and up == NULL):  # Paeth on the first row is Sub
                row[0] = src[0]
                for j in range(1, w):
                    row[j] = <unsigned char>(src[j] + row[j - 1])
            elif kind == 2:
                for j in range(w):
                    row[j] = <unsigned char>(src[j] + up[j])
            elif kind == 3:
                if up == NULL:
                    row[0] = src[0]
                    for j in range(1, w):
                        row[j] = <unsigned char>(src[j] + (row[j - 1] >> 1))
                else:
                    row[0] = <unsigned char>(src[0] + (up[0] >> 1))
                    for j in range(1, w):
                        row[j] = <unsigned char>(src[j] + ((<int>row[j - 1] + up[j]) >> 1))
            elif kind == 4:
                row[0] = <unsigned char>(src[0] + up[0])  # a = c = 0: the predictor is b
                for j in range(1, w):
                    a, b, c = row[j - 1], up[j], up[j - 1]
                    p = a + b - c
                    pa = p - a if p >= a else a - p
                    pb = p - b if p >= b else b - p
                    pc = p - c if p >= c else c - p
                    if pa <= pb and pa <= pc:
                        p = a
                    elif pb <= pc:
                        p = b
                    else:
                        p = c
                    row[j] = <unsigned char>(src[j] + p)
            else:
                bad = 1
                break
    return -1 if bad else 0
