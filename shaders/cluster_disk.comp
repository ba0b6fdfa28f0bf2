// meshcvt GPU kernel: the disk tests (a) and (b) of the topology-preserving filter, one invocation
// per proposal. Twin of ring_keeps_disks (src/cluster_iterate.cpp): among the faces of the moved
// face's vertex ring, those of the source cluster must be non-empty and edge-connected without
// the face, and those of the destination non-empty and edge-connected. Passing proposals get
// state 2.
//
// The members (ring faces of the two clusters, in increasing id) live in a private array of
// MAX_MEMBERS (specialization constant 1, chosen by the host from the mesh's largest vertex ring, so
// every ring fits; the counter COUNTER_OVERFLOW is a guard that the host turns into an error).
// Connectivity: grow the set reached from its lowest member by passes over the members until
// nothing changes; the same components as the CPU's bit-mask BFS / union-find.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "cluster_buffers.glsl"

layout(constant_id = 1) const uint MAX_MEMBERS = 64u;
layout(constant_id = 2) const uint MEMBER_WORDS = 2u;  // MAX_MEMBERS / 32

uint members[MAX_MEMBERS];
uint source_bits[MEMBER_WORDS];  // bit i: members[i] is in the source cluster (else the destination)
uint reached[MEMBER_WORDS];

bool bit(uint words[MEMBER_WORDS], uint i) { return (words[i >> 5] & (1u << (i & 31u))) != 0u; }

// Position of face g in members[0, count), or NONE (binary search: members are sorted).
uint find_member(uint g, uint count) {
  uint lo = 0u, hi = count;
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    if (members[mid] < g) lo = mid + 1u;
    else hi = mid;
  }
  return lo < count && members[lo] == g ? lo : NONE;
}

// The members with source bit == `source_side` are non-empty and edge-connected.
bool side_connected(Table t, uint count, bool source_side) {
  for (uint w = 0u; w < MEMBER_WORDS; ++w) reached[w] = 0u;
  uint first = NONE;
  for (uint i = 0u; i < count && first == NONE; ++i)
    if (bit(source_bits, i) == source_side) first = i;
  if (first == NONE) return false;
  reached[first >> 5] |= 1u << (first & 31u);
  bool grew = true;
  while (grew) {
    grew = false;
    for (uint i = 0u; i < count; ++i) {
      if (bit(source_bits, i) != source_side || bit(reached, i)) continue;
      for (int e = 0; e < 3; ++e) {
        uint o = t.adjacent.v[3u * members[i] + uint(e)];
        if (o == NONE) continue;
        uint j = find_member(o, count);  // the moved face is not in its own ring: never found
        if (j == NONE || bit(source_bits, j) != source_side || !bit(reached, j)) continue;
        reached[i >> 5] |= 1u << (i & 31u);
        grew = true;
        break;
      }
    }
  }
  for (uint i = 0u; i < count; ++i)
    if (bit(source_bits, i) == source_side && !bit(reached, i)) return false;
  return true;
}

void main() {
  const uint i = invocation_index();
  if (i >= pc.count) return;
  Table t = pc.table;
  const uint f = t.proposals.v[i];
  const uint source = t.labels.v[f];
  const uint destination = t.destination.v[f];
  for (uint w = 0u; w < MEMBER_WORDS; ++w) source_bits[w] = 0u;
  uint count = 0u;
  uint b[3], e[3];
  ring_begin(t, f, b, e);
  for (uint g = ring_next(t, f, b, e); g != NONE; g = ring_next(t, f, b, e)) {
    uint l = t.labels.v[g];
    if (l != source && l != destination) continue;
    if (count == MAX_MEMBERS) {  // cannot happen with the host's bound; refuse and report
      atomicMax(t.counters.v[COUNTER_OVERFLOW], 1u);
      return;
    }
    if (l == source) source_bits[count >> 5] |= 1u << (count & 31u);
    members[count++] = g;
  }
  if (side_connected(t, count, true) && side_connected(t, count, false)) t.state.v[f] = 2u;
}
