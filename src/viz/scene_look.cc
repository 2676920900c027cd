#include "viz/scene_look.h"

#include <GL/gl.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

namespace stance {

namespace {
constexpr int kSkySize = 128;          // texels per cube face
constexpr int kFloorSize = 512;        // texels per texture: 2 x 2 squares of 1 m
constexpr int kFloorLinePx = 3;        // the metre lines, on each side of a square's edge
constexpr float kTextureScale = 0.5f;  // texture coordinates per metre (see begin_render)
constexpr float kSkyTop[3] = {0.32f, 0.52f, 0.78f};
constexpr float kSkyHorizon[3] = {0.86f, 0.9f, 0.95f};
constexpr float kSkyBelow[3] = {0.5f, 0.53f, 0.56f};
constexpr unsigned char kFloorLight[3] = {168, 176, 184};
constexpr unsigned char kFloorDark[3] = {138, 146, 156};
constexpr unsigned char kFloorLine[3] = {205, 210, 216};
// the key light, from above, in front of and beside the default camera (looking along +y)
const Eigen::Vector3d kKeyDir = Eigen::Vector3d(0.35, 0.45, -1.0).normalized();
constexpr double kKeyDistance = 8.0;  // m from the focus, along the light

unsigned char to_byte(float x) {
  return static_cast<unsigned char>(std::lround(255 * std::clamp(x, 0.0f, 1.0f)));
}

// the sky's colour for a direction with vertical component z (-1..1): blue at the top, pale at
// the horizon, grey below it
void sky_colour(double z, unsigned char out[3]) {
  for (int k = 0; k < 3; ++k) {
    float c = z >= 0
                  ? kSkyHorizon[k] + (kSkyTop[k] - kSkyHorizon[k]) * float(std::pow(z, 0.6))
                  : kSkyHorizon[k] + (kSkyBelow[k] - kSkyHorizon[k]) * float(std::min(1.0, -8 * z));
    out[k] = to_byte(c);
  }
}

// a cube map whose colour depends on the height of the direction only. MuJoCo maps a skybox
// with (s, t, r) = (x, z, -y): the cube's t axis is up.
unsigned int make_sky_texture() {
  unsigned int tex = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_CUBE_MAP, tex);
  std::vector<unsigned char> rgb(3 * kSkySize * kSkySize);
  for (int face = 0; face < 6; ++face) {
    for (int row = 0; row < kSkySize; ++row)
      for (int col = 0; col < kSkySize; ++col) {
        double sc = 2 * (col + 0.5) / kSkySize - 1, tc = 2 * (row + 0.5) / kSkySize - 1;
        // the cube-map direction of this texel (OpenGL's face layout); its t component is up
        Eigen::Vector3d d;
        switch (face) {
          case 0:
            d = {1, -tc, -sc};
            break;
          case 1:
            d = {-1, -tc, sc};
            break;
          case 2:
            d = {sc, 1, tc};
            break;
          case 3:
            d = {sc, -1, -tc};
            break;
          case 4:
            d = {sc, -tc, 1};
            break;
          default:
            d = {-sc, -tc, -1};
            break;
        }
        // the lookup direction is (s, t, r) of the world's (x, z, -y) scaled by the texture
        // matrix: the world direction is (s, t) / scale and r
        Eigen::Vector3d world(d.x() / kTextureScale, d.y() / kTextureScale, d.z());
        sky_colour(world.y() / world.norm(), &rgb[3 * (row * kSkySize + col)]);
      }
    glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, 0, GL_RGB, kSkySize, kSkySize, 0, GL_RGB,
                 GL_UNSIGNED_BYTE, rgb.data());
  }
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  return tex;
}

// a 2 x 2 checker with light lines on the squares' edges: one square is one metre
unsigned int make_floor_texture() {
  std::vector<unsigned char> rgb(3 * kFloorSize * kFloorSize);
  const int square = kFloorSize / 2;
  for (int row = 0; row < kFloorSize; ++row)
    for (int col = 0; col < kFloorSize; ++col) {
      int r = row % square, c = col % square;
      bool line = r < kFloorLinePx || r >= square - kFloorLinePx || c < kFloorLinePx ||
                  c >= square - kFloorLinePx;
      bool light = ((row / square) + (col / square)) % 2 == 0;
      const unsigned char* colour = line ? kFloorLine : light ? kFloorLight : kFloorDark;
      std::copy_n(colour, 3, &rgb[3 * (row * kFloorSize + col)]);
    }
  unsigned int tex = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D, tex);
  // mipmaps: no shimmer far away
  glTexParameteri(GL_TEXTURE_2D, GL_GENERATE_MIPMAP, GL_TRUE);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB, kFloorSize, kFloorSize, 0, GL_RGB, GL_UNSIGNED_BYTE,
               rgb.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  return tex;
}

void set_light(mjvLight& l, const Eigen::Vector3d& dir, const Eigen::Vector3d& pos, float diffuse,
               float specular, bool shadow) {
  l = mjvLight{};
  for (int k = 0; k < 3; ++k) {
    l.pos[k] = static_cast<float>(pos[k]);
    l.dir[k] = static_cast<float>(dir[k]);
    l.diffuse[k] = diffuse;
    l.specular[k] = specular;
  }
  l.attenuation[0] = 1;
  l.cutoff = 180;
  l.exponent = 0;
  l.directional = 1;
  l.castshadow = shadow;
}
}  // namespace

bool model_has_own_look(const mjModel* m) {
  for (int i = 0; i < m->ntex; ++i)
    if (m->tex_type[i] == mjTEXTURE_SKYBOX) return true;
  return false;
}

bool is_floor_geom(const mjModel* m, int g) {
  if (m->body_weldid[m->geom_bodyid[g]] != 0) return false;
  int mat = m->geom_matid[g];
  if (mat >= 0 && m->mat_texid[mat] >= 0) return false;
  if (m->geom_type[g] == mjGEOM_PLANE) return true;
  if (m->geom_type[g] != mjGEOM_BOX) return false;
  double s[3] = {m->geom_size[3 * g], m->geom_size[3 * g + 1], m->geom_size[3 * g + 2]};
  std::sort(s, s + 3);
  return s[1] >= 1.0;
}

void SceneLook::attach(const mjModel* m, mjrContext& con) {
  active_ = !model_has_own_look(m) && con.ntexture + 2 <= 100;
  if (!active_) return;
  con.texture[con.ntexture] = make_sky_texture();
  con.textureType[con.ntexture++] = mjTEXTURE_SKYBOX;
  floor_texture_ = con.ntexture;
  con.texture[con.ntexture] = make_floor_texture();
  con.textureType[con.ntexture++] = mjTEXTURE_2D;
}

void SceneLook::begin_render() const {
  if (!active_) return;
  // MuJoCo 2.2 generates a plane's texture coordinates in metres, whatever the texrepeat: the
  // texture matrix halves them, so that the 2 x 2 checker spans 2 m (1 m squares). The sky's
  // cube map goes through the same matrix; make_sky_texture() undoes it.
  glActiveTexture(GL_TEXTURE0);
  glMatrixMode(GL_TEXTURE);
  glLoadIdentity();
  glScalef(kTextureScale, kTextureScale, 1);
  glMatrixMode(GL_MODELVIEW);
}

void SceneLook::end_render() const {
  if (!active_) return;
  glActiveTexture(GL_TEXTURE0);
  glMatrixMode(GL_TEXTURE);
  glLoadIdentity();
  glMatrixMode(GL_MODELVIEW);
}

void SceneLook::dress(const mjModel* m, mjvScene& scn, mjrContext& con,
                      const Eigen::Vector3d& focus, double shadow_radius_m) const {
  if (!active_) return;
  constexpr double kMinFloorHalf = 60;  // m: the floor reaches the horizon
  for (int i = 0; i < scn.ngeom; ++i) {
    mjvGeom& g = scn.geoms[i];
    if (g.objtype != mjOBJ_GEOM || g.objid < 0 || !is_floor_geom(m, g.objid)) continue;
    if (g.type == mjGEOM_BOX) {
      // the box's upper face as a plane: its thin axis is the plane's normal
      Eigen::Map<Eigen::Matrix<float, 3, 3, Eigen::RowMajor>> mat(g.mat);
      int thin = 0;
      for (int k = 1; k < 3; ++k)
        if (g.size[k] < g.size[thin]) thin = k;
      int a = (thin + 1) % 3, b = (thin + 2) % 3;
      Eigen::Vector3f n = mat.col(thin);
      if (n.z() < 0) n = -n;
      Eigen::Map<Eigen::Vector3f> pos(g.pos);
      pos += g.size[thin] * n;
      Eigen::Vector3f u = mat.col(a), v = n.cross(u);
      float half_u = g.size[a], half_v = g.size[b];
      mat.col(0) = u;
      mat.col(1) = v;
      mat.col(2) = n;
      g.size[0] = half_u;
      g.size[1] = half_v;
      g.size[2] = 0;
      g.type = mjGEOM_PLANE;
    }
    g.dataid = -1;
    for (int k = 0; k < 2; ++k)
      g.size[k] = static_cast<float>(std::max<double>(kMinFloorHalf, g.size[k]));
    g.texid = floor_texture_;
    g.texuniform = 1;
    g.texcoord = 0;
    g.texrepeat[0] = g.texrepeat[1] = 1;
    for (int k = 0; k < 4; ++k) g.rgba[k] = 1;
    g.reflectance = 0;  // a reflection draws the scene twice: too slow in software rendering
    g.specular = 0.1f;
    g.shininess = 0.1f;
    g.emission = 0;
  }
  // the headlight stays; the model's own lights make way for a key light with a shadow that
  // follows the character (one light: each costs a pass in software rendering)
  int kept = 0;
  for (int i = 0; i < scn.nlight; ++i)
    if (scn.lights[i].headlight) scn.lights[kept++] = scn.lights[i];
  scn.nlight = kept;
  if (scn.nlight < mjMAXLIGHT)
    set_light(scn.lights[scn.nlight++], kKeyDir, focus - kKeyDistance * kKeyDir, 0.6f, 0.3f, true);
  con.shadowClip = static_cast<float>(shadow_radius_m);
}

}  // namespace stance
