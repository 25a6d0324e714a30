"""Closing the 2014 Jaguar's TCP link lets the board read the last lines sent (the stop and the
E-stop) however busy it is. Closed at once with the board's reports unread, a socket resets the
connection; a board that writes before it reads (the virtual board's server does, each round)
then meets the reset first and drops the link without reading what was left: in one of the four
drives of test_safety_2014 on a starved machine the E-stop never arrived, and the next drive's
zero command was taken instead of refused."""

from __future__ import annotations

import socket
import threading
import time

from odolab.robot.jaguar2014.driver import TcpTransport


def test_a_board_that_writes_before_it_reads_still_gets_the_last_lines() -> None:
    with socket.create_server(("127.0.0.1", 0)) as server:
        host, port = server.getsockname()[:2]
        link = TcpTransport(host, port, time.monotonic)
        link.LINGER = 30.0  # the board closes its side below; the host's linger never runs out
        board, _ = server.accept()
        with board:
            board.sendall(b"MM0 C=1,2\r\n" * 3000)  # reports the host has not read
            time.sleep(0.05)
            link.send(b"MMW !M 0 0\r\nMMW !EM\r\n")
            closing = threading.Thread(target=link.close)
            closing.start()
            time.sleep(0.2)  # the board is busy; the host has closed meanwhile
            board.sendall(b"MM0 C=1,3\r\n")  # its next report first: a reset would raise here
            got = b""
            board.settimeout(2.0)
            while chunk := board.recv(65536):
                got += chunk
            board.close()  # the board's side closed: the host's linger ends
            closing.join(timeout=2.0)
            assert not closing.is_alive()
    assert got == b"MMW !M 0 0\r\nMMW !EM\r\n"


def test_close_gives_up_on_a_board_that_never_closes() -> None:
    with socket.create_server(("127.0.0.1", 0)) as server:
        host, port = server.getsockname()[:2]
        link = TcpTransport(host, port, time.monotonic)
        board, _ = server.accept()
        with board:
            started = time.monotonic()
            link.close()
            # bounded by TcpTransport.LINGER (0.5 s); measured 0.50 s; bound 5 s for a slow machine
            assert time.monotonic() - started < 5.0
