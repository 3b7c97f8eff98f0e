/* Between the course adapter (adapter.cpp, compiled with a student's code
 * into a shared object inside the sandbox) and rayd's evaluator, which
 * loads that object. Plain C so that both sides read it. Only doubles and
 * fixed arrays cross: nothing is allocated, nothing is owned. */
#ifndef RAYD_CODE_H
#define RAYD_CODE_H

#ifdef __cplusplus
extern "C" {
#endif

#define RAYD_CODE_ABI 1

/* The material's parameters as the scene gives them; the adapter copies
 * the ones its class has (kd, ks, shininess, roughness, ambient). */
typedef struct {
    double kd[3], ks[3], ambient[3];
    double shininess; /* phong, blinn_phong */
    double roughness; /* cook_torrance */
} rayd_code_material;

/* The course's HitRecord: unit shading normal, position, ray distance. */
typedef struct {
    double normal[3], position[3], t;
} rayd_code_hit;

/* Calls the student's calcReflectedLight(record, incomingDir, outgoingDir)
 * on a material of the class the adapter was compiled for (RAYD_CLASS),
 * built with m's parameters, and writes the returned vec3 to out. */
void rayd_code_reflected(const rayd_code_material *m, const rayd_code_hit *h, const double incoming[3],
                         const double outgoing[3], double out[3]);

/* RAYD_CODE_ABI, for the evaluator to check it loaded a matching object. */
int rayd_code_abi(void);

#ifdef __cplusplus
}
#endif

#endif
