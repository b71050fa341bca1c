"""The ZeroMQ service behind `pathcheck serve`: a ROUTER front end, a load-balancing broker
and worker processes (`broker`, `worker`), the versioned JSON protocol (`protocol`), one
function per op (`ops`), the folders requests may read (`roots`), CURVE keys (`keys`), the part
cache (`cache`) and the request recorder (`recorder`). The client is `checker.client`; the
protocol is documented in docs/protocol.md."""
