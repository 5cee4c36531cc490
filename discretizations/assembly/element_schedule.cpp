#include "discretizations/assembly/element_schedule.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>

namespace twill {

void ElementSchedule::add_phase(const std::vector<std::vector<int>>& groups) {
  Phase phase;
  for (const std::vector<int>& group : groups) {
    phase.elements.insert(phase.elements.end(), group.begin(), group.end());
    phase.group_start.push_back(static_cast<int>(phase.elements.size()));
  }
  phases_.push_back(std::move(phase));
}

ElementSchedule ElementSchedule::colouring(const ElementNodes& elements, int num_nodes) {
  std::vector<std::uint64_t> node_colours(static_cast<std::size_t>(num_nodes), 0);
  std::vector<std::vector<std::vector<int>>> colours;
  for (int e = 0; e < elements.size(); ++e) {
    std::uint64_t used = 0;
    for (int node : elements[e]) used |= node_colours[static_cast<std::size_t>(node)];
    int colour = 0;
    while (colour < 64 && (used >> colour) & 1u) ++colour;
    if (colour == 64) throw std::logic_error("ElementSchedule: colouring needs > 64 colours");
    for (int node : elements[e]) node_colours[static_cast<std::size_t>(node)] |= std::uint64_t{1} << colour;
    if (static_cast<int>(colours.size()) <= colour) colours.resize(static_cast<std::size_t>(colour + 1));
    colours[static_cast<std::size_t>(colour)].push_back({e});
  }
  ElementSchedule schedule;
  for (const auto& groups : colours) schedule.add_phase(groups);
  return schedule;
}

ElementSchedule ElementSchedule::alternating(const std::vector<std::vector<int>>& slabs) {
  ElementSchedule schedule;
  for (std::size_t parity = 0; parity < 2; ++parity) {
    std::vector<std::vector<int>> groups;
    for (std::size_t s = parity; s < slabs.size(); s += 2) groups.push_back(slabs[s]);
    schedule.add_phase(groups);
  }
  return schedule;
}

std::span<const int> ElementSchedule::groups(int phase, int first, int last) const {
  const Phase& p = phases_[static_cast<std::size_t>(phase)];
  const int begin = p.group_start[static_cast<std::size_t>(first)];
  const int end = p.group_start[static_cast<std::size_t>(last)];
  return {p.elements.data() + begin, static_cast<std::size_t>(end - begin)};
}

std::vector<int> ElementSchedule::elements() const {
  std::vector<int> out;
  for (const Phase& p : phases_) out.insert(out.end(), p.elements.begin(), p.elements.end());
  return out;
}

bool ElementSchedule::conflict_free(const ElementNodes& nodes, int num_nodes) const {
  std::vector<int> owner(static_cast<std::size_t>(num_nodes));
  for (int phase = 0; phase < num_phases(); ++phase) {
    std::fill(owner.begin(), owner.end(), -1);
    for (int g = 0; g < num_groups(phase); ++g)
      for (int e : groups(phase, g, g + 1))
        for (int node : nodes[e]) {
          int& o = owner[static_cast<std::size_t>(node)];
          if (o >= 0 && o != g) return false;
          o = g;
        }
  }
  return true;
}

std::size_t ElementSchedule::bytes() const {
  std::size_t total = 0;
  for (const Phase& p : phases_) total += (p.elements.capacity() + p.group_start.capacity()) * sizeof(int);
  return total;
}

}  // namespace twill
