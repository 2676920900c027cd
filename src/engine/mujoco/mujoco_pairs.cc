// MuJoCo's dynamic geom pairs predefined (engine/mujoco/mujoco_pairs.h).
#include "engine/mujoco/mujoco_pairs.h"

#include <fmt/format.h>

#include <algorithm>
#include <type_traits>

#include "core/error.h"

namespace stance {

namespace {

// the geom pairs mj_collision's dynamic pass may collide, in its order, with MuJoCo's filters:
// bitmask, same weld body, parent (unless disabled), and a collision function for the types
std::vector<std::pair<int, int>> dynamic_geom_pairs(const mjModel* m) {
  std::vector<std::pair<int, int>> pairs;
  const bool filter_parent = !(m->opt.disableflags & mjDSBL_FILTERPARENT);
  for (int b1 = 0; b1 < m->nbody; ++b1)
    for (int b2 = b1 + 1; b2 < m->nbody; ++b2) {
      const int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
      if (w1 == w2) continue;
      if (filter_parent && w1 && w2 &&
          (w1 == m->body_weldid[m->body_parentid[w2]] ||
           w2 == m->body_weldid[m->body_parentid[w1]]))
        continue;
      for (int g1 = m->body_geomadr[b1]; g1 < m->body_geomadr[b1] + m->body_geomnum[b1]; ++g1)
        for (int g2 = m->body_geomadr[b2]; g2 < m->body_geomadr[b2] + m->body_geomnum[b2]; ++g2) {
          if (!(m->geom_contype[g1] & m->geom_conaffinity[g2]) &&
              !(m->geom_contype[g2] & m->geom_conaffinity[g1]))
            continue;
          const int t1 = std::min(m->geom_type[g1], m->geom_type[g2]);
          const int t2 = std::max(m->geom_type[g1], m->geom_type[g2]);
          if (mjCOLLISIONFUNC[t1][t2]) pairs.emplace_back(g1, g2);
        }
    }
  return pairs;
}

// every geom of the pairs named and with the first one's contact parameters (so a pair's
// compiled parameters are the geoms' own, as the dynamic pass mixes them)
bool predefinable(const mjModel* m, const std::vector<std::pair<int, int>>& pairs) {
  constexpr size_t kMostPairs = 128;  // beyond: the broadphase's pruning may pay
  if (pairs.empty() || pairs.size() > kMostPairs || m->npair || m->nexclude ||
      m->opt.collision != mjCOL_ALL || mjcb_contactfilter)
    return false;
  const int g0 = pairs.front().first;
  auto same = [&](int g) {
    const char* name = mj_id2name(m, mjOBJ_GEOM, g);
    if (!name || !*name) return false;
    auto eq = [&](const mjtNum* a, int n) {
      return std::equal(a + n * g, a + n * g + n, a + n * g0);
    };
    return m->geom_condim[g] == m->geom_condim[g0] && m->geom_priority[g] == m->geom_priority[g0] &&
           eq(m->geom_friction, 3) && eq(m->geom_solref, mjNREF) && eq(m->geom_solimp, mjNIMP) &&
           eq(m->geom_margin, 1) && eq(m->geom_gap, 1) && eq(m->geom_solmix, 1);
  };
  for (const auto& [g1, g2] : pairs)
    if (!same(g1) || !same(g2)) return false;
  return true;
}

// the compiled pairs in `pairs`' order, their parameters checked against the geoms'
bool order_predefined_pairs(mjModel* m, const std::vector<std::pair<int, int>>& pairs) {
  if (m->npair != static_cast<int>(pairs.size())) return false;
  const int n = m->npair;
  std::vector<int> from(n, -1);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto [g1, g2] = pairs[i];
      if ((m->pair_geom1[j] == g1 && m->pair_geom2[j] == g2) ||
          (m->pair_geom1[j] == g2 && m->pair_geom2[j] == g1))
        from[i] = j;
    }
  if (std::count(from.begin(), from.end(), -1)) return false;
  auto permute = [&](auto* a, int width) {
    std::vector<std::remove_pointer_t<decltype(a)>> old(a, a + n * width);
    for (int i = 0; i < n; ++i)
      std::copy(&old[from[i] * width], &old[from[i] * width] + width, a + i * width);
  };
  permute(m->pair_dim, 1);
  permute(m->pair_geom1, 1);
  permute(m->pair_geom2, 1);
  permute(m->pair_signature, 1);
  permute(m->pair_solref, mjNREF);
  permute(m->pair_solimp, mjNIMP);
  permute(m->pair_margin, 1);
  permute(m->pair_gap, 1);
  permute(m->pair_friction, 5);
  const int g = pairs.front().first;
  const mjtNum* f = m->geom_friction + 3 * g;
  const mjtNum friction[5] = {f[0], f[0], f[1], f[2], f[2]};
  for (int i = 0; i < n; ++i)
    if (m->pair_dim[i] != m->geom_condim[g] || m->pair_margin[i] != m->geom_margin[g] ||
        m->pair_gap[i] != m->geom_gap[g] ||
        !std::equal(friction, friction + 5, m->pair_friction + 5 * i) ||
        !std::equal(m->geom_solref + mjNREF * g, m->geom_solref + mjNREF * (g + 1),
                    m->pair_solref + mjNREF * i) ||
        !std::equal(m->geom_solimp + mjNIMP * g, m->geom_solimp + mjNIMP * (g + 1),
                    m->pair_solimp + mjNIMP * i))
      return false;
  return true;
}

}  // namespace

mjModel* with_predefined_pairs(mjModel* m, std::vector<std::pair<std::string, std::string>> files,
                               size_t main, const std::string& name, MjcfReload reload) {
  const std::vector<std::pair<int, int>> pairs = dynamic_geom_pairs(m);
  std::string& text = files[main].second;
  const size_t end = text.rfind("</mujoco>");
  if (!predefinable(m, pairs) || end == std::string::npos) return m;
  std::string contact = "<contact>\n";
  for (const auto& [g1, g2] : pairs)
    contact += fmt::format("  <pair geom1=\"{}\" geom2=\"{}\"/>\n", mj_id2name(m, mjOBJ_GEOM, g1),
                           mj_id2name(m, mjOBJ_GEOM, g2));
  text.insert(end, contact + "</contact>\n");
  mjModel* predefined = nullptr;
  try {
    predefined = reload(files, name);
  } catch (const InputError&) {
    return m;
  }
  if (!order_predefined_pairs(predefined, pairs) || predefined->ngeom != m->ngeom) {
    mj_deleteModel(predefined);
    return m;
  }
  predefined->opt.collision = mjCOL_PAIR;
  mj_deleteModel(m);
  return predefined;
}

}  // namespace stance
