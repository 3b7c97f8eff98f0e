// Compiled with one student's code into a shared object that rayd's
// evaluator loads (rayd_code.h). Build (see README.md):
//   header upload: g++ -std=c++17 -O2 -fPIC -shared -I<course> -DRAYD_STUDENT_FILE='"<path of the header>"'
//                  -DRAYD_CLASS=PhongMaterial -DRAYD_KIND=2 adapter.cpp -o student.so
//   .cpp upload:   g++ -std=c++17 -O2 -fPIC -shared -I<course> -I<course>/decl -DRAYD_DECL_FILE='"PhongMaterial.h"'
//                  -DRAYD_CLASS=PhongMaterial -DRAYD_KIND=2 adapter.cpp <path of the .cpp> -o student.so
// RAYD_KIND: 1 diffuse, 2 phong, 3 blinn_phong, 4 cook_torrance.
// The student's file is included as it is, so the compiler's messages name
// that file and its own lines.
#if defined(RAYD_STUDENT_FILE)
#include RAYD_STUDENT_FILE
#elif defined(RAYD_DECL_FILE)
#include RAYD_DECL_FILE
#else
#error "define RAYD_STUDENT_FILE (a header upload) or RAYD_DECL_FILE (a .cpp upload)"
#endif

#include "rayd_code.h"

#include <limits>

#if !defined(RAYD_CLASS) || !defined(RAYD_KIND)
#error "define RAYD_CLASS (the material's class) and RAYD_KIND (1 to 4)"
#endif

static vec3 rayd_vec3(const double v[3]) { return vec3(v[0], v[1], v[2]); }

extern "C" void rayd_code_reflected(const rayd_code_material *m, const rayd_code_hit *h, const double incoming[3],
                                    const double outgoing[3], double out[3])
{
    try {
        RAYD_CLASS material; // the class the uploaded file defines, with a default constructor
        material.ambient = rayd_vec3(m->ambient);
        material.kd = rayd_vec3(m->kd);
#if RAYD_KIND == 2 || RAYD_KIND == 3
        material.ks = rayd_vec3(m->ks);
        material.shininess = m->shininess;
#elif RAYD_KIND == 4
        material.ks = rayd_vec3(m->ks);
        material.roughness = m->roughness;
#elif RAYD_KIND != 1
#error "RAYD_KIND is 1 (diffuse), 2 (phong), 3 (blinn_phong) or 4 (cook_torrance)"
#endif
        HitRecord record;
        record.normal = rayd_vec3(h->normal);
        record.position = rayd_vec3(h->position);
        record.t = h->t;
        const vec3 incomingDir = rayd_vec3(incoming), outgoingDir = rayd_vec3(outgoing);
        vec3 c = material.calcReflectedLight(record, incomingDir, outgoingDir);
        out[0] = c.x;
        out[1] = c.y;
        out[2] = c.z;
    } catch (...) {
        out[0] = out[1] = out[2] = std::numeric_limits<double>::quiet_NaN();
    }
}

extern "C" int rayd_code_abi(void) { return RAYD_CODE_ABI; }
