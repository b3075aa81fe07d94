"""The pymodbus adapter: serve a :class:`~simulator.modbus_device.ModbusDevice` over TCP or RTU.

The only module of the simulator that imports pymodbus (>= 3.13, < 4). It builds one
``SimDevice`` (device id 0: it answers every unit id; senders use 1) whose single
register block covers the whole map, with an ``action`` that forwards each request to the
device under the simulator's lock (reads are filled from the live controller, writes are
validated and may be refused with a Modbus exception). RTU runs over a pair of
pseudo-terminals bridged by the simulator: pymodbus opens one, the client the other.
"""

from __future__ import annotations

import asyncio
import threading
import time
from contextlib import AbstractContextManager

from pymodbus.constants import ExcCodes
from pymodbus.framer import FramerType
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from gcode.senders import modbus_map as mm
from simulator.modbus_device import ModbusDevice
from simulator.transports import LOCALHOST, PtyEndpoint

__all__ = ["ModbusEndpoint", "start_modbus_server"]

_READ_FC = frozenset({3, 4, 23})


def _sim_device(device: ModbusDevice, lock: AbstractContextManager, latency_s: float) -> SimDevice:
    async def action(
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        current_registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        if latency_s > 0.0:
            await asyncio.sleep(latency_s)
        with lock:
            if set_values is not None:
                values = [int(v) for v in set_values]
                device.last_write_s = time.monotonic()
                err = device.write(address, values)
                if err is not None:
                    return ExcCodes(err)
                device.service(device.last_service_s)
                return None
            result = device.read(address, count)
            if isinstance(result, int):
                return ExcCodes(result)
            off = address - start_address
            current_registers[off : off + count] = result
            return None

    block = SimData(0, count=mm.TOTAL_REGISTERS, values=0, datatype=DataType.REGISTERS)
    return SimDevice(0, simdata=[block], action=action)


class ModbusEndpoint:
    """A running Modbus server and how to reach it.

    Attributes
    ----------
    kind : str
        ``"tcp"`` or ``"rtu"``.
    port : int or None
        TCP port (127.0.0.1).
    path : str or None
        RTU: the pseudo-terminal the client opens (pymodbus ``AsyncModbusSerialClient``).
    """

    def __init__(self, kind: str, server: ModbusTcpServer | ModbusSerialServer) -> None:
        self.kind = kind
        self.server = server
        self.port: int | None = None
        self.path: str | None = None
        self._client_side: PtyEndpoint | None = None
        self._server_side: PtyEndpoint | None = None

    def bridge(self) -> None:
        """RTU: copy bytes between the two pseudo-terminals (call every loop cycle)."""
        a, b = self._client_side, self._server_side
        if a is None or b is None:
            return
        a.check_client()
        b.check_client()
        for src, dst in ((a, b), (b, a)):
            data = src.read()
            while data:
                n = dst.write(data)
                if n <= 0:
                    break
                data = data[n:]

    async def close(self) -> None:
        """Stop serving and release the endpoints."""
        await self.server.shutdown()
        for ep in (self._client_side, self._server_side):
            if ep is not None:
                ep.close()


async def start_modbus_server(
    device: ModbusDevice,
    lock: AbstractContextManager | None = None,
    *,
    kind: str = "tcp",
    port: int = 0,
    baud: int = 115200,
    latency_s: float = 0.0,
) -> ModbusEndpoint:
    """Start serving ``device`` in the running event loop.

    Parameters
    ----------
    device : ModbusDevice
        The register bank.
    lock : context manager or None
        Held around every device access (the simulator's lock).
    kind : str
        ``"tcp"`` (127.0.0.1:``port``, 0 = any free port) or ``"rtu"`` (pseudo-terminal).
    port : int
        TCP port.
    baud : int
        RTU baud rate given to pymodbus (a pseudo-terminal ignores it).
    latency_s : float
        Extra delay before every answer, s (fault injection).

    Returns
    -------
    ModbusEndpoint
        With the bound port or the device path.

    Raises
    ------
    ValueError
        For an unknown kind.
    OSError
        If the TCP port cannot be bound.
    """
    ctx = lock if lock is not None else threading.Lock()
    sim = _sim_device(device, ctx, latency_s)
    if kind == "tcp":
        server = ModbusTcpServer(sim, framer=FramerType.SOCKET, address=(LOCALHOST, int(port)))
        await server.serve_forever(background=True)
        if server.transport is None:
            raise OSError(f"Modbus TCP server could not listen on {LOCALHOST}:{port}")
        endpoint = ModbusEndpoint(kind, server)
        endpoint.port = server.transport.sockets[0].getsockname()[1]  # type: ignore[attr-defined]
        return endpoint
    if kind == "rtu":
        client_side, server_side = PtyEndpoint(), PtyEndpoint()
        server = ModbusSerialServer(
            sim, framer=FramerType.RTU, port=server_side.path, baudrate=baud, parity="N"
        )
        endpoint = ModbusEndpoint(kind, server)
        endpoint._client_side, endpoint._server_side = client_side, server_side
        endpoint.path = client_side.path
        await server.serve_forever(background=True)
        return endpoint
    raise ValueError(f"Modbus transport must be 'tcp' or 'rtu', got {kind!r}")
