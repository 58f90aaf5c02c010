"""Copy many numpy arrays into Taichi fields in one kernel launch.

``field.from_numpy`` compiles one small kernel for each field it fills (Taichi specialises
its copy kernel on the field), and each costs a front-end pass and a JIT compilation: about
50 ms a field on this 2-core CPU, paid again for every new model (a garment drape builds
two, each with some twenty fields). :func:`upload` fills a list of fields with one kernel,
specialised on the whole list: about half the time (measured: 20 fields of 10,000 entries,
1.07 s one by one, 0.55 s at once).
"""

import numpy as np
import taichi as ti

from sandbox import runtime

_INTEGER = (ti.i8, ti.i16, ti.i32, ti.i64, ti.u8, ti.u16, ti.u32, ti.u64)


def upload(pairs) -> None:
    """Fill each Taichi field with its numpy array: ``pairs`` is a list of ``(field,
    array)``; the array's first axis runs over the field's first entries (it may be shorter
    than the field), its other axes over the field's element (a vector's components, a
    matrix's rows and columns). Integer fields take their values from integer arrays, float
    fields from float arrays in the runtime's float type."""
    fields, layout, floats, ints = [], [], [], []
    f_off = i_off = 0
    for field, array in pairs:
        a = np.asarray(array)
        count = int(a.shape[0]) if a.ndim else 0
        if count == 0:
            continue
        shape = _element_shape(field)
        if a.shape[1:] != shape or count > field.shape[0]:
            raise ValueError(f"upload: an array of shape {a.shape} does not fit a field of "
                             f"{field.shape[0]} entries of shape {shape}")  # fmt: skip
        is_int = field.dtype in _INTEGER
        if is_int:
            ints.append(a.ravel().astype(np.int32))
            layout.append((i_off, count, shape, True))
            i_off += a.size
        else:
            floats.append(a.ravel().astype(runtime.float_dtype()))
            layout.append((f_off, count, shape, False))
            f_off += a.size
        fields.append(field)
    if not fields:
        return
    flat_f = np.concatenate(floats) if floats else np.zeros(1, runtime.float_dtype())
    flat_i = np.concatenate(ints) if ints else np.zeros(1, np.int32)
    _upload_kernel(tuple(fields), tuple(layout), flat_f, flat_i)


def _element_shape(field) -> tuple[int, ...]:
    ndim = getattr(field, "ndim", None)
    if ndim is None:
        return ()
    return (field.n,) if ndim == 1 else (field.n, field.m)


@ti.kernel
def _upload_kernel(fields: ti.template(), layout: ti.template(), floats: ti.types.ndarray(),
                   ints: ti.types.ndarray()):  # fmt: skip
    for k in ti.static(range(len(fields))):
        off, count, shape, is_int = ti.static(layout[k])
        for i in range(count):
            if ti.static(len(shape) == 0):
                if ti.static(is_int):
                    fields[k][i] = ints[off + i]
                else:
                    fields[k][i] = floats[off + i]
            elif ti.static(len(shape) == 1):
                for r in ti.static(range(shape[0])):
                    if ti.static(is_int):
                        fields[k][i][r] = ints[off + i * shape[0] + r]
                    else:
                        fields[k][i][r] = floats[off + i * shape[0] + r]
            else:
                for r, q in ti.static(ti.ndrange(shape[0], shape[1])):
                    if ti.static(is_int):
                        fields[k][i][r, q] = ints[off + (i * shape[0] + r) * shape[1] + q]
                    else:
                        fields[k][i][r, q] = floats[off + (i * shape[0] + r) * shape[1] + q]
