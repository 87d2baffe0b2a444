"""An animated GIF written frame by frame, so that memory holds one frame at any length (Pillow's
own animated save keeps every frame until the end). Pillow makes each frame's palette and LZW
data (as a one-frame GIF in memory); this module moves them into one stream: the header with a
loop extension, then per frame a delay and an image with its palette as a local colour table."""

from __future__ import annotations

import io
import struct
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray
from PIL import Image

_TRAILER = 0x3B
_EXTENSION = 0x21
_IMAGE = 0x2C


class GifStream:
    """Frames (H x W x 3 uint8, top row first) appended to an open binary file as an animated
    GIF that loops forever, each shown `delay_cs` hundredths of a second."""

    def __init__(self, handle: BinaryIO, size: tuple[int, int], delay_cs: int) -> None:
        self._handle = handle
        self._size = size
        self._delay = max(int(delay_cs), 2)  # viewers show shorter delays as 10 cs
        self.frames = 0
        width, height = size
        handle.write(b"GIF89a" + struct.pack("<HHBBB", width, height, 0, 0, 0))
        # NETSCAPE2.0 application extension: loop count 0 (forever).
        handle.write(b"\x21\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")

    def add(self, pixels: NDArray[np.uint8]) -> None:
        """One frame: quantised to its own palette of up to 256 colours."""
        if pixels.shape[1::-1] != self._size:
            raise ValueError(f"a frame of {pixels.shape[1::-1]} in a GIF of {self._size}")
        one = io.BytesIO()
        frame = Image.fromarray(np.ascontiguousarray(pixels)).convert(
            "P", palette=Image.Palette.ADAPTIVE
        )
        frame.save(one, format="GIF")
        palette, descriptor, data = _single_frame(one.getvalue())
        # Graphic control extension: no disposal, the delay, no transparency.
        self._handle.write(b"\x21\xf9\x04\x00" + struct.pack("<H", self._delay) + b"\x00\x00")
        # The image descriptor with the frame's palette as a local colour table.
        left, top, width, height, packed = struct.unpack("<HHHHB", descriptor)
        bits = (len(palette) // 3).bit_length() - 2  # table of 2^(bits + 1) colours
        packed = (packed & 0x40) | 0x80 | bits  # keep interlacing; local table on, its size
        self._handle.write(
            bytes([_IMAGE]) + struct.pack("<HHHHB", left, top, width, height, packed)
        )
        self._handle.write(palette + data)
        self.frames += 1

    def close(self) -> None:
        """The trailer, then the file is closed: a complete GIF."""
        self._handle.write(bytes([_TRAILER]))
        self._handle.close()

    def abort(self) -> None:
        """Close the file as it is (its writer removes it)."""
        self._handle.close()


def _single_frame(gif: bytes) -> tuple[bytes, bytes, bytes]:
    """(colour table, image descriptor's 9 bytes, LZW code size and data sub-blocks with their
    terminator) of the first image of a GIF; the table is the image's own, else the global one."""
    packed = gif[10]
    at = 13
    table = b""
    if packed & 0x80:
        size = 3 << ((packed & 7) + 1)
        table, at = gif[at : at + size], at + size
    while gif[at] == _EXTENSION:  # skip extensions: label, then sub-blocks up to a 0 byte
        at += 2
        while gif[at]:
            at += gif[at] + 1
        at += 1
    if gif[at] != _IMAGE:
        raise ValueError("no image in the GIF Pillow wrote")
    descriptor = gif[at + 1 : at + 10]
    at += 10
    if descriptor[8] & 0x80:
        size = 3 << ((descriptor[8] & 7) + 1)
        table, at = gif[at : at + size], at + size
    start = at
    at += 1  # LZW minimum code size
    while gif[at]:
        at += gif[at] + 1
    return table, descriptor, gif[start : at + 1]
