"""pymidi 0.5.0's own RTP-MIDI server, as the far end of `orch play --out rtpmidi:`.

It answers orch's invitations on both ports (OK), its clock sync (CK1), parses each MIDI
packet (pymidi's parser: the command section with running status, and the journal's header
and first channel journal, not its chapters) and takes orch's goodbye (BY).

    python3 server.py        prints {"event": "listening", "port": P}, then one JSON line
                             per peer connected / disconnected and per MIDI command.
"""

import json
import random
import sys

from pymidi import server


def out(**event):
    print(json.dumps(event), flush=True)


class Handler(server.Handler):
    def on_peer_connected(self, peer):
        out(event="connected", name=peer.name)

    def on_peer_disconnected(self, peer):
        out(event="disconnected", name=peer.name)

    def on_midi_commands(self, peer, commands):
        for c in commands:
            if c.command in ("note_on", "note_off"):
                out(event=c.command, channel=c.channel, key=int(c.params.key.intvalue
                    if hasattr(c.params.key, "intvalue") else c.params.key),
                    velocity=c.params.velocity)
            elif c.command == "control_mode_change":
                out(event="cc", channel=c.channel, controller=c.params.controller,
                    value=c.params.value)


def main():
    for _ in range(50):
        port = random.randrange(20000, 60000, 2)
        s = server.Server([("127.0.0.1", port)])
        try:
            s._init_protocols()
        except OSError:
            for sock in s.socket_map:
                sock.close()
            continue
        break
    else:
        sys.exit("no free port pair")
    s.add_handler(Handler())
    out(event="listening", port=port)
    while True:
        s._loop_once()


if __name__ == "__main__":
    main()
