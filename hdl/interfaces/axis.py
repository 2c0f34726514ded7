"""Thin AXI4-Stream video wrapper for the Verilog top (AMD PG278 names).

The wrapped component's ``i_stream``/``o_stream`` become ``s_axis_*``/``m_axis_*``:
``tdata`` carries ``data`` with every element (pixel or channel) zero-padded to a whole
number of bytes, element 0 in the least significant bits; ``tuser`` = ``first`` (start of
frame); ``tlast`` = ``last`` (end of line). Every other port of the wrapped component
(run-time settings, status) keeps its name. ``clk`` and ``rst`` (synchronous, active high)
come from the ``sync`` domain.
"""

from amaranth.hdl import Cat, Const, Module, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.hdl.interfaces.stream import element_bits

__all__ = ["AxisTop", "tdata_layout"]


def tdata_layout(data_shape):
    """(element bits, element count, padded element bits, tdata width) of a pixel data shape."""
    bits, count = element_bits(data_shape)
    padded = -(-bits // 8) * 8
    return bits, count, padded, padded * count


def _data_shape(stream_member):
    return stream_member.signature.members["payload"].shape["data"].shape


class AxisTop(wiring.Component):
    """Expose ``core``'s pixel streams as AXI4-Stream ports; forward its other ports.

    Purely combinational: adds no latency and no state.
    """

    def __init__(self, core):
        self._core = core
        csig = core.signature
        # a core without i_stream (a pipeline whose first stage is the sensor's front end)
        # has no s_axis ports
        self._in = (tdata_layout(_data_shape(csig.members["i_stream"]))
                    if "i_stream" in csig.members else None)
        # a core without o_stream (the camera's output links: pins, no stream) has no
        # m_axis ports
        self._out = (tdata_layout(_data_shape(csig.members["o_stream"]))
                     if "o_stream" in csig.members else None)
        members = {} if self._in is None else {
            "s_axis_tdata": In(self._in[3]),
            "s_axis_tvalid": In(1),
            "s_axis_tready": Out(1),
            "s_axis_tuser": In(1),
            "s_axis_tlast": In(1),
        }
        if self._out is not None:
            members |= {
                "m_axis_tdata": Out(self._out[3]),
                "m_axis_tvalid": Out(1),
                "m_axis_tready": In(1),
                "m_axis_tuser": Out(1),
                "m_axis_tlast": Out(1),
            }
        self._extra = []
        for name, member in csig.members.items():
            if name in ("i_stream", "o_stream"):
                continue
            if not member.is_port:
                raise TypeError(f"{name}: only plain ports can be exposed beside the streams")
            members[name] = In(member.shape) if member.flow == wiring.In else Out(member.shape)
            self._extra.append((name, member.flow))
        super().__init__(members)

    @property
    def core(self):
        return self._core

    @property
    def latency(self):
        return self._core.latency

    @property
    def port_domains(self):
        """The core's ``port_domains`` (the ports keep their names): {port: clock domain}
        of the ports outside the processing clock."""
        return dict(getattr(self._core, "port_domains", None) or {})

    @property
    def pin_ports(self):
        """The core's ``pin_ports``: {port: I/O attributes} of the ports that are device
        pins."""
        return dict(getattr(self._core, "pin_ports", None) or {})

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self._core
        if self._in is not None:
            i = core.i_stream
            bits, count, padded, _ = self._in
            m.d.comb += [
                i.valid.eq(self.s_axis_tvalid),
                self.s_axis_tready.eq(i.ready),
                i.payload.first.eq(self.s_axis_tuser),
                i.payload.last.eq(self.s_axis_tlast),
                Value.cast(i.payload.data).eq(
                    Cat(self.s_axis_tdata[k * padded:k * padded + bits] for k in range(count))),
            ]
        if self._out is not None:
            o = core.o_stream
            bits, count, padded, _ = self._out
            flat = Value.cast(o.payload.data)
            m.d.comb += [
                self.m_axis_tvalid.eq(o.valid),
                o.ready.eq(self.m_axis_tready),
                self.m_axis_tuser.eq(o.payload.first),
                self.m_axis_tlast.eq(o.payload.last),
                self.m_axis_tdata.eq(Cat(
                    Cat(flat[k * bits:(k + 1) * bits], Const(0, padded - bits))
                    for k in range(count))),
            ]
        for name, flow in self._extra:
            if flow == wiring.In:
                m.d.comb += getattr(core, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(core, name))
        return m
